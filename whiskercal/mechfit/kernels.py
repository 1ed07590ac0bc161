"""The fit's and the twin's compiled kernels (numba), compiled once into their on-disk cache.

Every kernel is compiled on its first call in a process and cached next to its module
(``__pycache__``); a fresh checkout's first fit, collect or test worker would otherwise spend
tens of seconds compiling them. ``make setup`` runs this module once after installing, so that
cost falls on the install.

    python -m whiskercal.mechfit.kernels
"""

from __future__ import annotations

import numpy as np


def compile_kernels() -> None:
    """Call each compiled kernel once with the types the twin and the fit pass it: a rod grid
    solved from first touch and again warm-started (``rod_batch``, ``elastica``), the twin's
    own rod, plane and shape solves, the magnet's interpolated field, and the fit's multipole
    basis."""
    from whiskercal.mechfit.forward import Suspension, rod_poses
    from whiskercal.mechfit.magnetmap import multipole_basis, start_geometries
    from whiskercal.twin.physics import magnet, mechanics
    from whiskercal.twin.physics.obstacles import Circle, plane_for_depth

    suspension = Suspension(75.0, 2.0, 0.06, 0.01)
    centers = np.array([[40.0, -3.0], [40.0, -4.0], [74.0, -3.0]])
    first = rod_poses(suspension, centers, 1.5)
    rod_poses(suspension, centers, 1.5, first)
    whisker = suspension.whisker()
    mechanics.solve_rod(whisker, centers[0], 1.5)
    mechanics.solve_shape(whisker, Circle(np.array([50.0, -4.0]), 1.5)).shape_mm(20)
    mechanics.solve_plane(whisker, plane_for_depth(whisker, 10.0))
    # poses inside the field table; shifts stacked column by column (Fortran order), as some
    # callers build them; and one pose outside the table (evaluated exactly beside the rest)
    magnet.field_uT(magnet.MagnetParams(), np.array([0.01, 0.02]), np.zeros((2, 2)))
    magnet.field_uT(magnet.MagnetParams(), np.array([0.01, 0.02]), np.zeros((2, 2), order="F"))
    magnet.field_uT(magnet.MagnetParams(), np.array([0.01, 3.0]), np.zeros((2, 2)))
    multipole_basis(start_geometries()[0], np.zeros((2, 3)))


if __name__ == "__main__":
    compile_kernels()
