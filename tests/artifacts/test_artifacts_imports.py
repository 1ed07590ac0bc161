"""whiskercal.artifacts sits below the pipeline stages: it must import none of them."""

from __future__ import annotations

import ast
from pathlib import Path

import whiskercal.artifacts

ABOVE = ("cli", "collect", "study", "fit", "regress", "report", "bench", "rig", "twin", "sim")


def _imported_modules(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
    return found


def test_artifacts_imports_no_stage_and_no_device_package():
    package = Path(whiskercal.artifacts.__file__).parent
    modules = sorted(package.glob("*.py"))
    assert {"raw_grid.py", "plane_study.py", "calibration.py"} <= {p.name for p in modules}
    forbidden = {f"whiskercal.{name}" for name in ABOVE}
    offending = {f"{path.name}: {module}" for path in modules for module in _imported_modules(path)
                 if any(module == f or module.startswith(f + ".") for f in forbidden)}
    assert offending == set()
