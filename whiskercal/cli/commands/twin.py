"""``whiskercal twin``: inspect and validate the digital twin."""

from __future__ import annotations

import click

from whiskercal.cli.app import abort, echo_json


@click.group("twin")
def command() -> None:
    """Inspect and validate the digital twin (whisker mechanics, contacts, scenes)."""


@command.command("cantilever")
@click.option("--alpha", type=float, required=True,
              help="Load parameter P·L²/EI of the tip load, in [0, 50].")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def cantilever(alpha: float, as_json: bool) -> None:
    """Tip of a rigid-root cantilever under a tip load perpendicular to its axis.

    Prints x (along the undeformed axis) and y (in the load's direction) as fractions of the
    length L, from the twin's elastica solver.
    """
    from whiskercal.twin.physics.cantilever import cantilever_tip

    x, y = cantilever_tip(alpha)
    if as_json:
        echo_json({"alpha": alpha, "x": x, "y": y})
        return
    click.echo(f"alpha = {alpha:g}: tip x/L = {x:.8f}, y/L = {y:.8f}")


@command.command("validate")
@click.option("--json", "as_json", is_flag=True, help="Print the checks as JSON.")
def validate(as_json: bool) -> None:
    """Check the mechanics against independent references; exit non-zero on any failure.

    Cantilever tips against Bisshopp & Drucker's closed form, the rigid-root limit, equilibrium
    residuals of rod, plane and polygon solves re-integrated by an independent ODE solver, and
    the friction cone along a slide.
    """
    from whiskercal.twin.validation.checks import run_all

    checks = run_all()
    if as_json:
        echo_json({"ok": all(c.ok for c in checks),
                   "checks": [{"name": c.name, "value": c.value, "limit": c.limit,
                               "ok": c.ok, "detail": c.detail} for c in checks]})
    else:
        width = max(len(c.name) for c in checks)
        click.echo(f"{'check':{width}s}  {'value':>11s}  {'limit':>9s}  result")
        for c in checks:
            click.echo(f"{c.name:{width}s}  {c.value:11.3e}  {c.limit:9.1e}  "
                       f"{'ok' if c.ok else 'FAIL'}  {c.detail}")
    failed = [c for c in checks if not c.ok]
    if failed:
        abort(f"{len(failed)} of {len(checks)} mechanics checks failed.")


def _depths(text: str) -> list[float]:
    from whiskercal.errors import UsageError

    try:
        return [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise UsageError(f"--depths must be numbers separated by commas, got {text!r}.") from None


@command.command("plane-study")
@click.option("--depths", default="5,10,15,20,25,30,35,40,45,50", show_default=True,
              help="Contact distances (mm) past the undeflected tip, comma-separated.")
@click.option("--k-rot", type=float, default=None,
              help="Root rotational stiffness (N·mm/rad) [default: the default whisker's].")
@click.option("--k-lin", type=float, default=None,
              help="Root translational stiffness (N/mm) [default: the default whisker's].")
@click.option("--mu-static", type=float, default=None, help="Static friction coefficient.")
@click.option("--mu-kinetic", type=float, default=None, help="Kinetic friction coefficient.")
@click.option("--tilt-deg", type=float, default=20.0, show_default=True,
              help="Tilt of the plane's normal from the whisker's axis (degrees).")
@click.option("--motion", type=click.Choice(["-1", "1"]), default=None,
              help="Direction the stage slides the plane along its tangent [default: the study's].")
@click.option("--json", "as_json", is_flag=True, help="Print the sweep as JSON.")
def plane_study(depths, k_rot, k_lin, mu_static, mu_kinetic, tilt_deg, motion, as_json):
    """The study's flat plane at each depth: contact kind, tip, root pose and force.

    Each depth is solved without history (steady kinetic sliding); this is the sweep that
    chose the mechanics' defaults (docs/twin.md).
    """
    import dataclasses
    import math

    from whiskercal.twin.validation.tuning import study_sweep, tangential_onset_mm
    from whiskercal.twin.physics.whisker import WhiskerParams

    changes = {"root_rotational_stiffness_n_mm_per_rad": k_rot,
               "root_translational_stiffness_n_per_mm": k_lin}
    whisker = dataclasses.replace(WhiskerParams(),
                                  **{k: v for k, v in changes.items() if v is not None})
    options = {"mu_static": mu_static, "mu_kinetic": mu_kinetic,
               "motion_sign": None if motion is None else int(motion)}
    options = {k: v for k, v in options.items() if v is not None}
    results = study_sweep(whisker, _depths(depths), tilt_rad=math.radians(tilt_deg), **options)
    onset = tangential_onset_mm(results)
    if as_json:
        echo_json({"tangential_onset_mm": None if math.isnan(onset) else onset,
                   "depths": [dataclasses.asdict(r) for r in results]})
        return
    click.echo(f"{'depth mm':>8s}  {'kind':10s}  {'tip x mm':>8s}  {'tip y mm':>8s}  "
               f"{'root deg':>8s}  {'shift mm':>8s}  {'|F| mN':>7s}")
    for r in results:
        click.echo(f"{r.depth_mm:8.1f}  {r.kind:10s}  {r.tip_mm[0]:8.2f}  {r.tip_mm[1]:8.2f}  "
                   f"{r.root_rotation_deg:8.2f}  {r.root_shift_mm:8.3f}  {r.force_mn:7.2f}")
    click.echo(f"tangential contact from {onset:g} mm" if not math.isnan(onset)
               else "no tangential contact at these depths")


def _describe_lines(d) -> list[str]:
    """The text form of a `twin.describe.SensorDescription`, units on every number."""
    sensor, whisker, push = d.sensor, d.sensor.whisker, d.push
    lines = [
        f"sensor {sensor.sensor_id}: {whisker.length_mm:g} mm x {whisker.diameter_mm:g} mm wire, "
        f"tip {whisker.reach_mm:g} mm from the centre of rotation",
        f"  EI                 {d.bending_stiffness_n_mm2:.4g} N·mm²",
        f"  k_θ·L/EI           {d.root_ratio:.3g}  (k_θ {whisker.root_rotational_stiffness_n_mm_per_rad:g} "
        "N·mm/rad; large: a push bends the wire, small: it turns the root)",
        "  static field       " + ", ".join(f"{a} {v:.0f}" for a, v in zip("XYZ", d.static_field_uT)) + " µT",
        f"paper's deflection: the study's plane (tilted {push.tilt_deg:g}°, μ_s {push.mu_static:.2f}, "
        f"μ_k {push.mu_kinetic:.2f}) {push.depth_mm:g} mm past the undeflected tip",
    ]
    if push.kind == "failed":
        lines.append("  no equilibrium found at this depth")
    else:
        lines += [f"  contact            {push.kind}" + ("" if push.kind == "tip" else "  (not a tip contact)"),
                  f"  tip                ({push.tip_mm[0]:.2f}, {push.tip_mm[1]:.2f}) mm",
                  f"  force              {push.force_n:.3g} N", f"  z                  {push.z_uT:.0f} µT"]
    return lines + _range_lines(d.one_to_one) + _saturation_lines(d.saturation)


def _range_lines(one) -> list[str]:
    why = {"fold": f"z turns back at a tip slope of {abs(one.tip_slope_rad):.2f} rad",
           "sweep_end": f"z is monotonic over the whole sweep, to a tip slope of {one.swept_to_rad:.2f} rad",
           "contact_lost": f"z is monotonic as far as the rod holds the tip, a tip slope of "
                           f"{one.swept_to_rad:.2f} rad"}
    return [f"one-to-one z range   {one.z_range_uT[0]:.0f} .. {one.z_range_uT[1]:.0f} µT "
            "(frictionless tip contact)",
            f"  ends               {why[one.ends_at]}",
            f"  tip there          ({one.tip_mm[0]:.2f}, {one.tip_mm[1]:.2f}) mm"]


def _saturation_lines(sat) -> list[str]:
    where = ("none over the tip-contact sweep" if sat.axis is None
             else f"already at rest, on {sat.axis}" if sat.at_rest
             else f"at z = {sat.z_uT:.0f} µT, first on {sat.axis}")
    scale = " / ".join(f"±{v / 1000:.1f}" for v in sat.full_scale_uT)
    use = ", ".join(f"{a} {share:.0%}" for a, share in zip("XYZ", sat.peak_fraction))
    return [f"saturation           {where}",
            f"  range              GAIN_SEL {sat.gain}, RES {sat.res}: {scale} mT on X / Y / Z",
            f"  peak use           {use} of the range over the sweep"]


@command.command("describe")
@click.argument("sensor", metavar="ID_OR_PATH")
@click.option("--depth", type=float, default=40.0, show_default=True,
              help="How far the study's plane is pushed past the undeflected tip, mm "
                   "(40: the paper's deflection target).")
@click.option("--json", "as_json", is_flag=True, help="Print the description as JSON.")
def describe(sensor: str, depth: float, as_json: bool) -> None:
    """The numbers a builder needs before calibrating a sensor (a shipped id or a .toml file).

    EI, k_θ·L/EI, the tip's force and z under the paper's deflection, the z range over which the
    tip is a one-to-one function of z, and the z at which the magnetometer saturates.
    """
    from whiskercal.twin.describe import describe as describe_sensor, description_to_dict
    from whiskercal.twin.sensor_file import resolve_sensor

    description = describe_sensor(resolve_sensor(sensor), depth)
    if as_json:
        echo_json(description_to_dict(description))
        return
    click.echo("\n".join(_describe_lines(description)))
