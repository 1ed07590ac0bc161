"""The choices of a fit: ``FitOptions``, one field per option of ``whiskercal fit`` (mm, µT)."""

from __future__ import annotations

from dataclasses import dataclass

from whiskercal.checks import number, positive
from whiskercal.errors import UsageError
from whiskercal.model.calibrate import MAX_EXTENSION_MM, CalibrationOptions

COORDINATES = ("polar", "cartesian")
TRACERS = ("fast", "paper")
INTERPOLANTS = ("auto", "linear", "cubic", "pchip", "akima", "polynomial")
SAMPLES_RANGE = (2, 10_000)
TIP_MODELS = ("auto", "mechanics", "level-set")
# The trace length MAX_EXTENSION_MM was measured for (mm): the default sensor's.
REFERENCE_TRACE_LENGTH_MM = 78.0


@dataclass(frozen=True)
class FitOptions:
    """What ``fit`` does with a raw grid; each field is the ``whiskercal fit`` option of its name.

    Attributes
    ----------
    degree : int or "auto"
        Total degree of the surface polynomial (the model accepts 1..8), or "auto" (k-fold CV,
        1-SE rule).
    coordinates : str
        Variables of the surface polynomial: "polar" (r, θ about the root) or "cartesian" (x, y).
    samples : int
        Tips precomputed for the lookup, evenly spread over the calibrated z range.
    tracer : str
        Level-set tracer: "fast" (adaptive) or "paper" (fixed 1e-3 mm step).
    interpolant : str
        Lookup interpolant; "auto" picks the smallest hold-out error.
    trace_length_mm : float or None
        Arc length from the root to the tip, mm; None: the raw grid's rig config, else the twin
        sensor of the same id (``resolve_trace_length``).
    entry_radius_mm : float or None
        Radius about the root where the trace enters the data, mm; None: a third of the trace
        length, at least the grid's nearest point.
    max_extension_mm : float or None
        Longest straight extrapolation of a tip past the grid that is trusted, mm; None:
        ``model.calibrate.MAX_EXTENSION_MM`` scaled by trace length / 78 mm.
    allow_extrapolation : bool
        Keep a calibration whose tips lie farther past the grid, with that z range marked.
    rod_correction : bool
        Move the rod centres by the rod radius onto the shaft before the final fit.
    threshold_uT : float or None
        Collision threshold stored for the runtime, µT from the static reading; None: the
        paper's 300 µT, lowered on builds where 300 µT is a tip moved more than 3 mm
        (``fit.contact_threshold``).
    tip_model : str
        The lookup shipped: "auto" (default: the mechanics-informed model where the grid
        identifies it, else the level set; the (Y, Z) joint fit's where the table's fit
        estimates it closer, ``fit.tip_model.adopt_joint_lookup``), "mechanics" or
        "level-set" (the paper's). The
        mechanics is fitted in every case for the error estimate (``fit.tip_model``).
    field_table : bool
        Also fit the mechanics with the magnet's map to Y and Z and store the (Y, Z) -> tip
        table (``fit.field_table``) for tip contacts with friction or at a slant (default;
        ``--no-field-table`` leaves it out). Withheld, with a warning, where the fit's own
        estimate says it cannot be trusted.
    """

    degree: int | str = 5
    coordinates: str = "polar"
    samples: int = 20
    tracer: str = "fast"
    interpolant: str = "auto"
    trace_length_mm: float | None = None
    entry_radius_mm: float | None = None
    max_extension_mm: float | None = None
    allow_extrapolation: bool = False
    rod_correction: bool = True
    threshold_uT: float | None = None
    tip_model: str = "auto"
    field_table: bool = True

    def __post_init__(self) -> None:
        # the degree's range is the model's to check (FitError), as it is for every caller
        if not (self.degree == "auto" or (isinstance(self.degree, int)
                                          and not isinstance(self.degree, bool))):
            raise UsageError(f"degree must be a degree 1..8 or 'auto', not {self.degree!r}")
        for name, allowed in (("coordinates", COORDINATES), ("tracer", TRACERS),
                              ("interpolant", INTERPOLANTS), ("tip_model", TIP_MODELS)):
            if getattr(self, name) not in allowed:
                raise UsageError(f"{name} must be one of {', '.join(allowed)}, "
                                 f"not {getattr(self, name)!r}")
        low, high = SAMPLES_RANGE
        if not (isinstance(self.samples, int) and low <= self.samples <= high):
            raise UsageError(f"samples must be an integer {low}..{high}, not {self.samples!r}")
        if self.max_extension_mm is not None:
            number(self.max_extension_mm, "max_extension_mm", low=0, unit="mm")
        if self.threshold_uT is not None:
            positive(self.threshold_uT, "threshold_uT (the collision threshold)", unit="µT")
        if self.trace_length_mm is not None:
            positive(self.trace_length_mm, "trace_length_mm (root to tip)", high=1000, unit="mm")

    def calibration_options(self, trace_length_mm: float) -> CalibrationOptions:
        """The model's options for this fit, with the trace length (mm) already resolved.

        Raises
        ------
        UsageError
            The entry radius is not inside half the trace length: the trace looks for its
            entry on circles out to half the length (``model.trace.find_entry``), so a larger
            radius leaves no circle to try.
        """
        entry = self.entry_radius_mm
        if entry is not None and not 0 < entry < trace_length_mm / 2:
            raise UsageError(f"--entry-radius-mm must lie between 0 and half the trace length "
                             f"({trace_length_mm / 2:g} mm), not {entry:g} mm")
        return CalibrationOptions(
            degree=self.degree, coordinates=self.coordinates, samples=self.samples,
            tracer=self.tracer, lookup_kind=self.interpolant, trace_length_mm=trace_length_mm,
            entry_radius_mm=self.entry_radius_mm, correct_rod_radius=self.rod_correction,
            max_extension_mm=self.extension_limit_mm(trace_length_mm),
            allow_extrapolation=self.allow_extrapolation)

    def extension_limit_mm(self, trace_length_mm: float) -> float:
        """The extrapolation limit (mm): as given, else the one measured for the default's
        78 mm trace length scaled with the build's (a whisker's deflected shape scales with it)."""
        if self.max_extension_mm is not None:
            return self.max_extension_mm
        return MAX_EXTENSION_MM * trace_length_mm / REFERENCE_TRACE_LENGTH_MM
