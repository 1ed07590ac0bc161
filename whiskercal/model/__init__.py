"""Calibration models: arrays in, arrays out (numpy/scipy only, no I/O).

- ``surface``: the measurement model z = f(x, y), a scaled Legendre polynomial.
- ``trace`` (with ``ode``): tip extraction by tracing the level set f = z from the root.
- ``lookup``: tips precomputed over the calibrated range and a fast interpolant z -> tip.
- ``kalman``, ``collision``: the constant-state filter and contact detection.
- ``calibrate``: the whole fit from a raw grid's arrays.
- ``errors``: the expected failures, each a ``WhiskercalError``.

docs/model.md explains the choices and the measured accuracy.
"""
