"""The second twin engine: the whisker's statics by settling a MuJoCo model.

It exists to cross-check the quasi-static elastica on the same static cases, with a different
discretization and solver (see :mod:`whiskercal.twin.engines.mujoco_model` for the two representations,
a hinge chain and a 1-D elastic flex). Loads are dead loads (fixed direction) applied at material
points of the shaft; the model is stepped with MuJoCo's implicit ``discrete`` integrator until a
step moves it less than a tolerance, which is its static equilibrium.

MuJoCo is an optional dependency (``pip install whiskercal[bench]``); importing this module
works without it, building an engine raises a clear error.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError, WhiskercalError
from whiskercal.twin.engines.mujoco_model import RodSpec, build_mjcf, settle_settings

_log = logging.getLogger(__name__)

# 4.0 gave 1-D flexes their rod elasticity (bending from Young's modulus) and the `discrete`
# integrator the semantics the models here are tuned for.
MIN_MUJOCO_MAJOR = 4

# How far the touch rod moves per step on its way in (units of L).
_ROD_STEP = 0.005


class SettleError(WhiskercalError):
    """The MuJoCo model did not come to rest within its step budget."""


@dataclass(frozen=True)
class MujocoStatic:
    """A settled equilibrium, in the whisker frame (mm, rad).

    Attributes
    ----------
    tip_mm : ndarray (2,)
        Tip position.
    shape_mm : ndarray (N+1, 2)
        Vertices from the clamped end of the wire to the tip.
    root_rotation_rad : float
        Rotation of the suspension (0 for a rigid root).
    root_shift_mm : ndarray (2,)
        Translation of the suspension's centre of rotation.
    steps : int
        Integrator steps taken to settle.
    """

    tip_mm: np.ndarray
    shape_mm: np.ndarray
    root_rotation_rad: float
    root_shift_mm: np.ndarray
    steps: int


def _import_mujoco():
    try:
        import mujoco
    except ImportError as exc:  # the engine is optional; say how to get it
        raise UsageError("MuJoCo is not installed; install it with "
                         "`pip install whiskercal[bench]`.") from exc
    major = int(mujoco.__version__.split(".")[0])
    if major < MIN_MUJOCO_MAJOR:
        raise UsageError(f"MuJoCo {mujoco.__version__} is too old for the whisker models; "
                         f"install mujoco>={MIN_MUJOCO_MAJOR}.0.")
    # MuJoCo's default warning handler appends to MUJOCO_LOG.TXT in the working directory; the
    # flex's effective-metric solve warns at residuals near 1e-10, which are harmless here.
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(lambda message: _log.debug("MuJoCo: %s", message.strip()))
    return mujoco


class MujocoWhisker:
    """A compiled MuJoCo whisker at one resolution, solving static load cases.

    Parameters
    ----------
    spec : RodSpec
        The wire and its root.
    segments : int
        Segments along the shaft.
    representation : {"chain", "flex"}
        Hinge chain (exactly inextensible) or 1-D elastic flex (soft inextensibility).
    rod_radius_mm : float, optional
        Give the chain a touch rod of this radius for `solve_rod` (MuJoCo contact).
    """

    def __init__(self, spec: RodSpec, segments: int = 40, representation: str = "chain",
                 rod_radius_mm: float | None = None) -> None:
        self._mj = _import_mujoco()
        self.spec = spec
        self.segments = segments
        self.representation = representation
        self.rod_radius_mm = rod_radius_mm
        self.settings = settle_settings(representation, segments)
        xml = build_mjcf(spec, segments, representation, rod_radius_mm)
        self.model = self._mj.MjModel.from_xml_string(xml)
        self.data = self._mj.MjData(self.model)
        self._root_qpos = {name: self._qpos_address(name)
                           for name in ("root_x", "root_y", "root_theta")}

    def solve_tip_load(self, force_n) -> MujocoStatic:
        """Equilibrium under a dead load at the tip.

        Parameters
        ----------
        force_n : array_like (2,)
            Force on the tip in the whisker frame (N).
        """
        return self.solve_point_load(self.spec.length_mm, force_n)

    def solve_point_load(self, arc_mm: float, force_n) -> MujocoStatic:
        """Equilibrium under a dead load at the material point ``arc_mm`` from the clamped end.

        Parameters
        ----------
        arc_mm : float
            Arc length from the clamped end of the wire (0..L, mm).
        force_n : array_like (2,)
            Force in the whisker frame (N); it keeps its direction as the shaft bends.
        """
        if not 0.0 <= arc_mm <= self.spec.length_mm:
            raise UsageError(f"load position {arc_mm} mm is off the shaft "
                             f"(0..{self.spec.length_mm} mm).")
        force = np.zeros(3)
        force[:2] = np.asarray(force_n, dtype=float) / self.spec.force_scale_n
        steps = self._settle(arc_mm / self.spec.length_mm, force)
        return self._result(steps)

    def solve_rod(self, rod_center_mm) -> MujocoStatic:
        """Equilibrium against the touch rod, through MuJoCo's frictionless contact.

        The rod comes from the +y side, as in the quasi-static `solve_rod`: it is placed where
        it just touches the undeflected wire and moved to ``rod_center_mm`` in small steps
        (the contact then finds the branch the rig reaches), and the model settles there.

        Parameters
        ----------
        rod_center_mm : array_like (2,)
            The rod's centre in the whisker frame (mm).
        """
        if self.rod_radius_mm is None:
            raise UsageError("this MuJoCo whisker was built without a touch rod (rod_radius_mm).")
        length = self.spec.length_mm
        target = np.asarray(rod_center_mm, dtype=float) / length
        start = np.array([target[0], self.rod_radius_mm / length])
        approach = max(0.0, start[1] - target[1])
        steps = self._settle_moving_rod(start, target, int(np.ceil(approach / _ROD_STEP)))
        return self._result(steps)

    def _settle_moving_rod(self, start: np.ndarray, target: np.ndarray, approach_steps: int) -> int:
        """Move the rod from ``start`` to ``target`` over the first steps, then settle."""
        mj, model, data = self._mj, self.model, self.data
        rod = mj.mj_name2id(model, mj.mjtObj.mjOBJ_GEOM, "rod")
        mj.mj_resetData(model, data)
        dt = self.settings.timestep
        model.opt.timestep = dt
        for step in range(1, self.settings.max_steps + 1):
            share = min(1.0, step / max(approach_steps, 1))
            model.geom_pos[rod, :2] = start + share * (target - start)
            mj.mj_step(model, data)
            if share == 1.0 and np.max(np.abs(data.qvel)) * dt < self.settings.step_tolerance:
                return step
        raise SettleError(f"the MuJoCo chain ({self.segments} segments) did not settle against the "
                          f"rod within {self.settings.max_steps} steps.")

    def _settle(self, arc: float, force: np.ndarray) -> int:
        """Step from rest until a step moves the model less than the tolerance."""
        mj, model, data = self._mj, self.model, self.data
        mj.mj_resetData(model, data)
        mj.mj_forward(model, data)
        dt = self.settings.timestep_for(self._load_sensitivity(force))
        model.opt.timestep = dt
        tol = self.settings.step_tolerance
        for step in range(1, self.settings.max_steps + 1):
            self._apply(arc, force)
            mj.mj_step(model, data)
            if np.max(np.abs(data.qvel)) * dt < tol:
                return step
        raise SettleError(
            f"the MuJoCo {self.representation} model ({self.segments} segments) did not settle "
            f"within {self.settings.max_steps} steps."
        )

    def _load_sensitivity(self, force: np.ndarray) -> float:
        """How fast the load's moments change with rotation, against the softest stiffness.

        In scaled units the wire's stiffness is EI/L = 1; a softer root hinge makes the same
        load relatively stronger. The lever is the whole whisker plus the root offset.
        """
        spec = self.spec
        stiffness = 1.0
        if spec.root_rotational_stiffness_n_mm_per_rad is not None:
            root = spec.root_rotational_stiffness_n_mm_per_rad * spec.length_mm
            stiffness = min(1.0, root / spec.bending_stiffness_n_mm2)
        lever = 1.0 + abs(spec.root_offset_mm) / spec.length_mm
        return float(np.linalg.norm(force)) * lever / stiffness

    def _apply(self, arc: float, force: np.ndarray) -> None:
        """Write the dead load at material coordinate ``arc`` (0..1) into ``qfrc_applied``."""
        data = self.data
        data.qfrc_applied[:] = 0.0
        for body, point, weight in self._material_point(arc):
            self._mj.mj_applyFT(self.model, data, weight * force, np.zeros(3), point, body,
                                data.qfrc_applied)

    def _material_point(self, arc: float) -> list[tuple[int, np.ndarray, float]]:
        """(body id, world point, share of the load) carrying the material point at ``arc``."""
        seg = 1.0 / self.segments
        index = min(int(arc / seg), self.segments - 1)
        local = arc - index * seg
        if self.representation == "chain":
            body = self.model.body(f"seg{index}").id
            axis = self.data.xmat[body].reshape(3, 3)[:, 0]
            point = self.data.xpos[body] + local * axis
            return [(body, point, 1.0)]
        # Flex vertex 0 is the ghost behind the root, vertex 1 the root, vertex 1 + j at j·l.
        # Between two vertices the load is shared linearly: its equivalent nodal forces.
        share = local / seg
        first, second = index + 1, index + 2
        return [
            (int(self.model.flex_vertbodyid[v]), self.data.flexvert_xpos[v].copy(), w)
            for v, w in ((first, 1.0 - share), (second, share))
            if w > 0.0
        ]

    def _result(self, steps: int) -> MujocoStatic:
        self._mj.mj_fwdPosition(self.model, self.data)
        shape = self._shape() * self.spec.length_mm
        qpos = self.data.qpos
        root = {name: (qpos[adr] if adr is not None else 0.0)
                for name, adr in self._root_qpos.items()}
        return MujocoStatic(
            tip_mm=shape[-1].copy(),
            shape_mm=shape,
            root_rotation_rad=float(root["root_theta"]),
            root_shift_mm=np.array([root["root_x"], root["root_y"]]) * self.spec.length_mm,
            steps=steps,
        )

    def _shape(self) -> np.ndarray:
        """Vertices from the clamp to the tip in scaled units, (N+1, 2)."""
        data = self.data
        if self.representation == "flex":
            return data.flexvert_xpos[1:, :2].copy()
        ids = [self.model.body(f"seg{i}").id for i in range(self.segments)]
        clamp = data.xpos[ids[0], :2]
        # Each segment's inertial point sits at its far end (see mujoco_model).
        return np.vstack([clamp, data.xipos[ids, :2]])

    def _qpos_address(self, joint_name: str) -> int | None:
        joint_id = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_JOINT, joint_name)
        return None if joint_id < 0 else int(self.model.jnt_qposadr[joint_id])
