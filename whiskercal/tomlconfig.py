"""TOML configuration files: documented defaults overridden by a user's file, key by key."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path
from typing import Any

from whiskercal.errors import UsageError
from whiskercal.paths import not_regular_reason


def read_toml(path: str | Path) -> dict[str, Any]:
    """A TOML file as a nested dict, with one clear error when it is missing or not TOML."""
    path = Path(path)
    reason = not_regular_reason(path)
    if reason is not None:
        raise UsageError(f"{path}: {reason}")
    try:
        with open(path, "rb") as handle:
            return tomllib.load(handle)
    except FileNotFoundError:
        raise UsageError(f"{path}: no such config file") from None
    except tomllib.TOMLDecodeError as error:
        raise UsageError(f"{path}: not valid TOML ({error})") from None
    except UnicodeDecodeError as error:
        raise UsageError(f"{path}: not valid TOML (not UTF-8 text: byte {error.start})") from None
    except RecursionError:  # tomllib parses nested arrays and tables by recursion
        raise UsageError(f"{path}: not valid TOML for whiskercal (nested too deeply)") from None
    except OSError as error:
        raise UsageError(f"{path}: cannot read the config file ({error.strerror or error})") from None


def merge_overrides(base: dict[str, Any], override: dict[str, Any], where: str = "config") -> dict[str, Any]:
    """``base`` updated by ``override``; a key ``base`` does not know is refused, so a typo in a
    user's file is an error rather than a silently ignored setting."""
    merged = copy.deepcopy(base)
    for key, value in override.items():
        if key not in merged:
            raise UsageError(f"{where}: unknown setting {key!r} (known: {', '.join(sorted(merged))})")
        if isinstance(merged[key], dict):
            if not isinstance(value, dict):
                raise UsageError(f"{where}: {key!r} must be a table")
            merged[key] = merge_overrides(merged[key], value, f"{where} [{key}]")
        else:
            merged[key] = value
    return merged
