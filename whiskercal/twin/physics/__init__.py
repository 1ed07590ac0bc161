"""The whisker's statics, the obstacles it meets, the magnet's field and the magnetometer.

Pure and deterministic: arrays and frozen dataclasses in and out, no clock, no I/O.
``mechanics`` is the one import for every contact solve; ``sensor`` puts one sensor build's
statics and field behind the interface a simulated rig calls.
"""
