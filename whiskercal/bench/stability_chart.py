"""The stability map as one PNG: a panel per probe, failures marked by how they were reported.

Filled circles are numbers that came back (their error against the truth or the reference);
crosses at the bottom of a panel are detected failures (an exception or an analysis flag),
labelled with the exception's name; red rings mark silent failures (a number, but a wrong one);
orange rings mark a documented limit of the method (wrong numbers that no run-time check can see,
measured here and stated in docs/bench.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from matplotlib.ticker import NullFormatter

from whiskercal.bench.stability import RETURNED
from whiskercal.plotting import pyplot, save_png

PANELS = (
    ("z_range", "fast", "tracer (fast): z beyond the data", "z (µT)", "error_vs_truth_mm"),
    ("domain", None, "grid cut short of the tip", "grid reach (mm)", "max_error_vs_truth_mm"),
    ("paper_step", None, "paper trace: step size", "step (mm)", "error_vs_reference_mm"),
    ("noise", None, "reading noise", "noise (µT)", "max_error_vs_truth_mm"),
    ("plane_slip", None, "plane study: slip into tangential contact", "depth (mm)",
     "true_tangential_fraction"),
    ("stiffness_ratio", None, "k_θ·L/EI sweep", "k_θ·L/EI", "max_error_vs_truth_mm"),
    ("vanishing_gradient", None, "ridge of zero gradient", "z (µT)", None),
)


def _entries(probes: dict, name: str, sub: str | None) -> list[dict]:
    probe = probes.get(name, {})
    probe = probe.get(sub, {}) if sub else probe
    return probe.get("entries", []) if isinstance(probe, dict) else []


def _value(entry: dict, y_key: str | None) -> float:
    value = entry.get(y_key, np.nan) if y_key else np.nan
    return 0.0 if value is None or not np.isfinite(value) else float(value)


def _panel(ax, entries: list[dict], title: str, x_label: str, y_key: str | None) -> None:
    ok = [e for e in entries if e["status"] in RETURNED]
    failed = [e for e in entries if e["status"] not in RETURNED]
    if ok:
        ax.plot([e["setting"] for e in ok], [_value(e, y_key) for e in ok], "o", color="C0",
                ms=4, label="returned a value")
    silent = [e for e in entries if e.get("silent") and not e.get("documented_limit")]
    documented = [e for e in entries if e.get("documented_limit")]
    for group, color, label in ((silent, "red", "silent failure"),
                                (documented, "darkorange", "documented limit (not detected)")):
        if y_key is not None and group:
            ax.plot([e["setting"] for e in group], [_value(e, y_key) for e in group], "o",
                    mfc="none", mec=color, ms=10, label=label)
    for e in failed:
        ax.plot(e["setting"], _value(e, y_key), "x", color="C3", ms=8)
        ax.annotate(e["status"].replace("Error", ""), (e["setting"], _value(e, y_key)), fontsize=6,
                    rotation=60, xytext=(2, 4), textcoords="offset points", color="C3")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel(x_label, fontsize=8)
    ax.set_ylabel(y_key or "", fontsize=7)
    ax.grid(True, alpha=0.3)
    if ok or silent or documented:
        ax.legend(fontsize=6)


def _kalman_table(ax, cases: list[dict]) -> None:
    ax.axis("off")
    lines = [f"{c['case']}: {c['status']}, finite={c['finite']}" for c in cases]
    ax.text(0.0, 1.0, "Kalman filter\n" + "\n".join(lines), va="top", fontsize=7, family="monospace",
            wrap=True)


def draw_stability(result: dict, path: str | Path) -> Path:
    """Write the stability map of ``stability.run()`` as a PNG."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 4, figsize=(18, 8))
    probes = result["probes"]
    for ax, (name, sub, title, x_label, y_key) in zip(axes.flat, PANELS):
        _panel(ax, _entries(probes, name, sub), title, x_label, y_key)
        if name in ("paper_step", "stiffness_ratio", "noise"):
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())
        if name == "vanishing_gradient":
            ax.set_xscale("symlog", linthresh=1e-6)
    _kalman_table(axes.flat[-1], probes.get("kalman", []))
    fig.suptitle("whiskercal stability map: values returned, failures detected (x), "
                 "silent failures (red), documented limits (orange)")
    return save_png(fig, path, dpi=100)
