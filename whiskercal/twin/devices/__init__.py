"""The twin's emulated devices: the stage and sensor boards speaking the firmware's protocols
(``boards`` runs both on one clock), the stage's mechanics, the simulated clock and serial line,
and the ``sim://`` ports and ptys."""
