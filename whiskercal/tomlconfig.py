"""TOML configuration files: documented defaults overridden by a user's file, key by key."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path
from typing import Any

from whiskercal.errors import UsageError
from whiskercal.paths import not_regular_reason


def read_toml(path: str | Path) -> dict[str, Any]:
    """A TOML file as a nested dict, with one clear error when it is missing or not TOML
    (not UTF-8, bad syntax, or nested deeper than the parser can follow)."""
    path = Path(path)
    reason = not_regular_reason(path)
    if reason is not None:
        raise UsageError(f"{path}: {reason}")
    try:
        with open(path, "rb") as handle:
            return tomllib.load(handle)
    except FileNotFoundError:
        raise UsageError(f"{path}: no such config file") from None
    except UnicodeDecodeError as error:
        raise UsageError(f"{path}: not valid TOML (not UTF-8 text: byte {error.start})") from None
    except tomllib.TOMLDecodeError as error:
        raise UsageError(f"{path}: not valid TOML ({error})") from None
    except RecursionError:
        raise UsageError(f"{path}: not valid TOML (arrays or tables nested too deep)") from None
    except OSError as error:
        raise UsageError(f"{path}: cannot read the config file ({error.strerror or error})") from None


def merge_overrides(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    """``base`` updated by ``override`` key by key, tables merged table by table.

    Nothing is checked here: the typed table the result is read into (``whiskercal.typedconfig``)
    refuses a key ``base`` does not know, so a typo in a user's file is an error rather than a
    silently ignored setting, and a value of the wrong type.
    """
    merged = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(merged.get(key), dict) and isinstance(value, dict):
            merged[key] = merge_overrides(merged[key], value)
        else:
            merged[key] = value
    return merged
