"""Every whiskercal file layout: one module per HDF5 schema, each the only place that knows it.

- ``raw_grid``: schema ``whiskercal.raw_grid``; ``RawGridWriter`` (appends point by point, what
  collect's checkpoint drives) and ``read_raw_grid``.
- ``plane_study``: schema ``whiskercal.plane_study``; ``StudyWriter`` (adds finished trials
  atomically, resumable) and ``read_study``.
- ``calibration``: schema ``whiskercal.calibration``; ``write_calibration`` (and
  ``write_with_target`` for the next version with a study's target) and ``read_calibration``.
- ``contour_run``: schema ``whiskercal.contour_run``; ``write_contour_run``, ``read_contour_run``.
- ``replay_track``: schema ``whiskercal.replay_track``; ``write_track``, ``read_track``.
- ``h5io``: the shared conventions: provenance attributes, the schema check, datasets with units.

Each schema module defines ``SCHEMA``, ``SCHEMA_VERSION`` (semver) and ``SUPPORTED_MAJOR`` and
the plain data types its files hold. Every file carries root attributes ``schema``,
``schema_version``, ``created`` (ISO 8601 with zone), ``whiskercal_version``, ``sensor_id``, the
SHA-256 of its inputs and its config (JSON); every dataset carries a ``units`` attribute; a reader
refuses another schema or an unknown major version with one clear ``ArtifactError``. Nothing here
ever unpickles. docs/formats.md describes each layout.

A new file type goes here as a new module named after its schema (``whiskercal.<name>`` in
``<name>.py``) with those constants, one writer and one reader built on ``h5io``, an entry in the
list above and a section in docs/formats.md, and a fixture per shipped version under
``tests/fixtures/`` that every later release must still load.

This package sits below the pipeline stages (collect, study, fit, regress, report, bench) and
imports none of them, nor cli, rig or twin: it knows files, not how they are made.
"""
