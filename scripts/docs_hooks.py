"""mkdocs hooks: render generated content into the pages at build time.

- ``<!-- figure: NAME -->``: a table from a JSON snapshot (``scripts/docs_figures.py``);
- ``<!-- api: MODULE -->``: the public classes and functions of MODULE with their signatures
  and docstrings, so the API reference is the code's own words.

An unknown figure or module fails the build: a page never shows a stale or typed table.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # scripts/ is not a package

import docs_figures  # noqa: E402

MARKER = re.compile(r"<!--\s*(figure|api):\s*([\w.\-]+)\s*-->")


def _doc(obj) -> str:
    return inspect.cleandoc(obj.__doc__ or "")


def _signature(name: str, obj) -> str:
    try:
        return f"{name}{inspect.signature(obj)}"
    except (TypeError, ValueError):
        return name


def _members(module):
    names = getattr(module, "__all__", None) or [n for n in vars(module) if not n.startswith("_")]
    for name in names:
        obj = getattr(module, name)
        if (inspect.isclass(obj) or inspect.isfunction(obj)) and obj.__module__ == module.__name__:
            yield name, obj


def _class_methods(cls):
    for name, member in vars(cls).items():
        if name.startswith("_") or not (inspect.isfunction(member) or isinstance(member, property)):
            continue
        yield name, member


def api_markdown(module_name: str) -> str:
    """The module's docstring, then each public class (with its methods) and function."""
    module = importlib.import_module(module_name)
    parts = [f"## `{module_name}`\n", _doc(module), ""]
    for name, obj in _members(module):
        parts += [f"### `{_signature(name, obj)}`\n", _doc(obj), ""]
        if inspect.isclass(obj):
            for method, member in _class_methods(obj):
                target = member.fget if isinstance(member, property) else member
                title = f"{name}.{method}" if isinstance(member, property) else \
                    f"{name}.{_signature(method, member)}"
                parts += [f"#### `{title}`\n", _doc(target), ""]
    return "\n".join(parts)


def _replace(match: re.Match) -> str:
    kind, name = match.groups()
    return docs_figures.render(name) if kind == "figure" else api_markdown(name)


def on_page_markdown(markdown: str, page, config, files) -> str:
    """mkdocs hook: replace every marker of the page by what it stands for."""
    return MARKER.sub(_replace, markdown)
