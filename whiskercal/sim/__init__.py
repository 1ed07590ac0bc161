"""The ``sim://`` scheme: where a device URL meets the twin.

pyserial finds the handler for ``sim://NAME/stage`` and ``sim://NAME/sensor`` as
``whiskercal.sim.protocol_sim``. This package sits above both the rig clients and the twin, so
neither imports the other: the clients only open URLs, and the twin only serves them.
``whiskercal`` registers this package with pyserial on import (``register()``).
"""

HANDLER_PACKAGE = "whiskercal.sim"


def register() -> None:
    """Let ``serial.serial_for_url`` open ``sim://`` URLs (idempotent)."""
    import serial

    if HANDLER_PACKAGE not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(HANDLER_PACKAGE)
