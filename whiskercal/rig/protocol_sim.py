"""pyserial looks up the handler for ``sim://`` URLs as ``<package>.protocol_sim``; the
handler itself is the twin's (``whiskercal.twin.simport``)."""

from whiskercal.twin.simport import Serial

__all__ = ["Serial"]
