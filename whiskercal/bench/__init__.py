"""Speed-versus-accuracy studies and the stability map behind whiskercal's defaults.

Each comparison module exposes ``run(quick=False, progress=None) -> dict``: rows of (setting,
time per call, error against a reference) plus a ``pareto`` entry that says how to chart them and a
``supports`` entry that names the default the measurements justify. :mod:`whiskercal.bench.runner`
runs them in one process and writes JSON and PNG charts (``whiskercal bench``).
"""
