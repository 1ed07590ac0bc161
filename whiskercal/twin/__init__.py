"""The digital twin: the rig simulated honestly enough to be the ground truth.

Sub-packages, from the bottom up:

- ``physics``: the whisker's statics (elastica, root suspension, contacts with rods, planes,
  polygons; friction), the obstacles it meets, the magnet's field and the magnetometer.
  Pure functions and frozen dataclasses; no clock, no I/O.
- ``engines``: the second engine (MuJoCo) that cross-checks ``physics``.
- ``validation``: checks of ``physics`` against references that do not use its solver, and the
  sweeps behind its defaults.
- ``params`` (a sensor build), ``sensor_file`` (a build as a TOML file or dict), ``describe``
  (the numbers a builder needs before calibrating), ``truth`` (what the real rig never knows: z for a pose, the
  true tip for a z).
- ``scenes``: what rides on the stage (rod, plane, shapes), each answering its own contact
  question through one small protocol (``scenes.base.Scene``); a registry finds them by name.
- ``geometry`` (the whisker frame in stage coordinates), ``contact_path`` (the equilibrium
  followed along the stage's path), ``truth_record`` (the ground truth of every sample).
- ``world``: one simulated rig wired from those parts and the devices.
- ``devices``: the emulated boards that speak the firmware's serial protocols, the simulated
  clock and serial line, and the ``sim://`` ports and ptys.
"""
