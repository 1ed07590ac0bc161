"""HDF5 files: raw datasets, calibration artifacts and study datasets.

Every file carries root attributes ``schema``, ``schema_version`` (semver), ``created`` (ISO 8601
with zone), ``whiskercal_version``, ``sensor_id``, the SHA-256 of its inputs and its config (JSON).
Every dataset carries a ``units`` attribute. Nothing here ever unpickles.
"""
