"""The twin's emulated devices: the stage and sensor boards speaking the firmware's protocols,
the stage's mechanics, the simulated clock and serial line, and the ``sim://`` ports and ptys."""
