"""The kernels ``make setup`` compiles ahead: every compiled kernel of the project among them."""

import importlib
import os
import pkgutil
import subprocess
import sys

import pytest
from numba.core.registry import CPUDispatcher

import whiskercal


def _kernel_names() -> set[str]:
    """``module.function`` of every numba kernel in whiskercal (all live in twin.physics) but
    those inlined into their callers, which are never compiled on their own."""
    names = set()
    for module in pkgutil.walk_packages(whiskercal.__path__, "whiskercal."):
        if ".physics." not in module.name:
            continue
        loaded = importlib.import_module(module.name)
        names |= {f"{module.name.rsplit('.', 1)[1]}.{name}" for name, value in vars(loaded).items()
                  if isinstance(value, CPUDispatcher) and value.__module__ == module.name
                  and value.targetoptions.get("inline") != "always"}
    return names


@pytest.mark.slow
def test_compiling_ahead_caches_every_kernel(tmp_path):
    # a cache of its own, empty: each kernel compiled here is written there under its name
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    subprocess.run([sys.executable, "-m", "whiskercal.mechfit.kernels"], env=env, check=True,
                   timeout=600)
    cached = {path.name.split("-")[0] for path in tmp_path.rglob("*.nbi")}
    kernels = _kernel_names()
    assert len(kernels) >= 20
    assert kernels - cached == set()
