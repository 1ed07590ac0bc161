"""Checks of the twin's mechanics against independent references, and the sweeps behind its defaults."""
