"""pyserial's handler for ``sim://`` URLs: the twin's in-process serial ports."""

from whiskercal.twin.devices.simport import Serial

__all__ = ["Serial"]
