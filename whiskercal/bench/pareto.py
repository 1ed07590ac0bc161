"""Pareto fronts of time against error, and the charts that show them (PNG, matplotlib Agg).

A comparison's result carries a ``pareto`` entry naming the row keys to draw: ``x`` (time per
call, s, drawn on a log axis), ``y`` (error), ``series`` (row keys whose values name a series),
optionally ``panel`` (a row key that splits the chart into panels) and ``label`` (a row key
written next to each point). Rows with ``"default": True`` are the chosen defaults and are marked.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.plotting import pyplot, save_png


def pareto_mask(time_s: Sequence[float], error: Sequence[float]) -> np.ndarray:
    """True for the non-dominated points: no other point is at least as fast and as accurate,
    and strictly better in one of the two. Non-finite points are never on the front."""
    x, y = np.asarray(time_s, float), np.asarray(error, float)
    finite = np.isfinite(x) & np.isfinite(y)
    mask = np.zeros(len(x), bool)
    for k in np.flatnonzero(finite):
        others = finite & (x <= x[k]) & (y <= y[k]) & ((x < x[k]) | (y < y[k]))
        mask[k] = not others.any()
    return mask


def front_rows(rows: list[dict], x_key: str, y_key: str) -> list[dict]:
    """The rows on the Pareto front, fastest first."""
    mask = pareto_mask([r.get(x_key, np.nan) for r in rows], [r.get(y_key, np.nan) for r in rows])
    chosen = [row for row, on in zip(rows, mask) if on]
    return sorted(chosen, key=lambda r: r[x_key])


def _series_name(row: dict, keys: Sequence[str]) -> str:
    return " / ".join(str(row.get(k, "")) for k in keys)


def _panels(rows: list[dict], panel_key: str | None) -> dict[str, list[dict]]:
    if panel_key is None:
        return {"": rows}
    panels: dict[str, list[dict]] = {}
    for row in rows:
        panels.setdefault(str(row.get(panel_key, "")), []).append(row)
    return panels


def _draw_panel(ax, rows: list[dict], spec: dict) -> None:
    x_key, y_key, label_key = spec["x"], spec["y"], spec.get("label")
    series: dict[str, list[dict]] = {}
    for row in rows:
        series.setdefault(_series_name(row, spec.get("series", [])), []).append(row)
    for name, members in series.items():
        members = sorted(members, key=lambda r: r[x_key])
        ax.plot([r[x_key] for r in members], [r[y_key] for r in members], "o-", ms=4, lw=1,
                alpha=0.8, label=name or None)
        for r in members if label_key else []:
            ax.annotate(str(r.get(label_key, "")), (r[x_key], r[y_key]), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
    front = front_rows(rows, x_key, y_key)
    if front:
        ax.step([r[x_key] for r in front], [r[y_key] for r in front], where="post", color="k",
                lw=1.5, ls="--", label="Pareto front")
    defaults = [r for r in rows if r.get("default")]
    if defaults:
        ax.plot([r[x_key] for r in defaults], [r[y_key] for r in defaults], "*", ms=16,
                mfc="gold", mec="k", label="default", zorder=5)
    ax.set_xscale("log")
    if spec.get("log_y", True) and all(r[y_key] > 0 for r in rows if np.isfinite(r[y_key])):
        ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)


def draw_pareto(rows: list[dict], spec: dict, path: str | Path, title: str = "") -> Path:
    """Draw time (log x) against error, one series per ``spec["series"]`` value, front and defaults.

    Parameters
    ----------
    rows : list of dict
        Measurements; each has the keys ``spec["x"]`` and ``spec["y"]``.
    spec : dict
        ``x``, ``y``, ``series`` (list of keys), optional ``panel``, ``label``, ``x_label``,
        ``y_label``, ``log_y`` (default True).
    path : path
        PNG to write.
    """
    drawable = [r for r in rows if np.isfinite(r.get(spec["x"], np.nan))
                and np.isfinite(r.get(spec["y"], np.nan))]
    if not drawable:
        raise UsageError(f"nothing to chart for {title or path}: no row has finite time and error")
    panels = _panels(drawable, spec.get("panel"))
    plt = pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.2), squeeze=False)
    for ax, (name, members) in zip(axes[0], panels.items()):
        _draw_panel(ax, members, spec)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel(spec.get("x_label", spec["x"]))
        ax.set_ylabel(spec.get("y_label", spec["y"]))
    if title:
        fig.suptitle(title)
    return save_png(fig, path)
