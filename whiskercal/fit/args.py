"""``FitOptions`` from the words of a ``whiskercal fit`` command line, without click.

A recorded dataset's golden results name the fit they came from as ``whiskercal fit`` arguments
(``golden.json``'s ``pipeline.fit_args``, docs/formats.md), so the regression reads them here.
The options are the command's own; a test holds the two lists together.
"""

from __future__ import annotations

from typing import Callable, Sequence

from whiskercal.errors import UsageError
from whiskercal.fit.options import FitOptions


def parse_degree(word: str) -> int | str:
    """``auto`` or a whole degree, from the word of a command line; UsageError otherwise."""
    if word == "auto":
        return word
    try:
        return int(word)
    except ValueError:
        raise UsageError(f"--degree must be a degree 1..8 or 'auto', not {word!r}") from None


def _number(kind: type, flag: str) -> Callable[[str], float | int]:
    def convert(word: str):
        try:
            return kind(word)
        except ValueError:
            raise UsageError(f"{flag} must be a number, not {word!r}") from None
    return convert


# option -> (FitOptions field, how its value word converts)
VALUED: dict[str, tuple[str, Callable[[str], object]]] = {
    "--degree": ("degree", parse_degree),
    "--coordinates": ("coordinates", str),
    "--samples": ("samples", _number(int, "--samples")),
    "--tracer": ("tracer", str),
    "--interpolant": ("interpolant", str),
    "--trace-length-mm": ("trace_length_mm", _number(float, "--trace-length-mm")),
    "--entry-radius-mm": ("entry_radius_mm", _number(float, "--entry-radius-mm")),
    "--max-extension-mm": ("max_extension_mm", _number(float, "--max-extension-mm")),
    "--threshold-uT": ("threshold_uT", _number(float, "--threshold-uT")),
    "--tip-model": ("tip_model", str),
}
# flag -> (FitOptions field, the value the flag sets)
FLAGS: dict[str, tuple[str, bool]] = {
    "--allow-extrapolation": ("allow_extrapolation", True),
    "--no-rod-correction": ("rod_correction", False),
    "--field-table": ("field_table", True),
    "--no-field-table": ("field_table", False),
}


def options_from_args(words: Sequence[str]) -> FitOptions:
    """The ``FitOptions`` that ``whiskercal fit RAW --out OUT [words]`` runs with.

    ``--name value`` and ``--name=value`` are both read; a later option overrides an earlier one.

    Raises
    ------
    UsageError
        For an unknown option, a missing or malformed value, or a value ``FitOptions`` refuses.
    """
    chosen: dict[str, object] = {}
    words = list(words)
    while words:
        word = words.pop(0)
        flag, has_value, value = word.partition("=")
        if flag in FLAGS and not has_value:
            field, setting = FLAGS[flag]
            chosen[field] = setting
        elif flag in VALUED:
            if not has_value:
                if not words:
                    raise UsageError(f"{flag} needs a value")
                value = words.pop(0)
            field, convert = VALUED[flag]
            chosen[field] = convert(value)
        else:
            raise UsageError(f"no such option of whiskercal fit: {word}")
    return FitOptions(**chosen)
