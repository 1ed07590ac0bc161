"""matplotlib for every figure whiskercal draws: headless, imported only when a figure is made."""

from __future__ import annotations

from pathlib import Path

from whiskercal.atomic import atomic_path
from whiskercal.errors import UsageError
from whiskercal.paths import ensure_dir


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed; imported lazily so that
    commands that draw nothing start fast)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out ``fig``, write it as a PNG (creating the directory), close it; return the path.

    The file is replaced atomically: a process killed while drawing leaves the old figure or none.
    """
    path = Path(path)
    ensure_dir(path.parent)
    try:
        fig.tight_layout()
        with atomic_path(path) as scratch:
            fig.savefig(scratch, dpi=dpi, format="png")  # the scratch name has no .png suffix
    except OSError as error:  # a full disk: the old figure is kept
        raise UsageError(f"cannot write {path}: {error.strerror or error} (any old file is "
                         "kept)") from None
    finally:
        pyplot().close(fig)
    return path
