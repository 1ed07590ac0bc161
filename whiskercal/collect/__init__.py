"""Collecting the calibration grid: plans, the acquisition loop, checkpoint and resume.

- ``config``: the run's settings (``default_grid.toml`` documents every key).
- ``plan``: which rod positions, in what order, along which path; frames.
- ``sweep``: the tip sweep's rod positions (the rod at the tip, after the grid).
- ``estimate``: stage time and limit checks of a plan (``--dry-run``).
- ``loop`` and ``recorder``: the acquisition loop over injected stage and sensor clients.
- ``journal`` and ``checkpoint``: the crash-proof side journal and resuming from it; the raw
  dataset itself (schema ``whiskercal.raw_grid``) is ``whiskercal.artifacts.raw_grid``.
- ``twin_truth``: the twin's ground truth per point.
- ``run``: one run from ports to file, what ``whiskercal collect`` calls.
"""
