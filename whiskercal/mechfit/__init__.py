"""Mechanics-informed calibration: an elastica on a suspension, fitted to the rod grid.

The level-set method (``whiskercal.model``) takes the tip for a given z from the shape of a level
set of z over rod positions, which is the whisker's shape under a shaft contact, not the locus of
its tip under a tip contact. This package fits a physical model instead, the planar elastica on a
root that turns and shifts (the twin's mechanics, ``whiskercal.twin.physics``, used as a forward
model with fitted parameters only) plus a low-order map from the root's pose to the field axes,
and solves it for tip contacts to build the runtime's tables. docs/calibration.md has the method
and the measurements.
"""
