"""The ``sim://`` scheme: where a device URL meets the twin.

pyserial finds the handler for ``sim://NAME/stage`` and ``sim://NAME/sensor`` as
``whiskercal.sim.protocol_sim`` (``whiskercal`` adds this package to pyserial's handler
packages on import). It sits above both the rig clients and the twin, so neither imports the
other: the clients only open URLs, and the twin only serves them.
"""
