"""The flat-plane optimal-depth study: run it on the rig, analyse it, choose the deflection target.

``config`` (TOML defaults and the plane's geometry), ``run`` and ``recorder`` (the acquisition,
into the study file of ``whiskercal.artifacts.plane_study``), ``truth`` (the twin's ground truth
per sample), ``localize``, ``detect``, ``analysis``, ``target`` and ``report`` (the analysis),
``artifact_target`` (the target in a new artifact version), ``figures``. docs/study.md
describes the study.
"""
