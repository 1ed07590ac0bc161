"""matplotlib for every figure whiskercal draws: headless, imported only when a figure is made."""

from __future__ import annotations

from pathlib import Path

from whiskercal.paths import ensure_dir


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed; imported lazily so that
    commands that draw nothing start fast)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out ``fig``, write it as a PNG (creating the directory), close it; return the path."""
    path = Path(path)
    ensure_dir(path.parent)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)
    return path
