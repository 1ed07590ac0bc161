"""Short twin studies for the tests: the slide cut, moves off the slide fast, the first-contact
search coarse (the study tests' shared config text)."""

FAST_OFF_THE_SLIDE = """approach_speed_mm_s = 30.0
rapid_speed_mm_s = 60.0
retract_mm = 3.0
[contact]
search_step_mm = 0.25
samples_per_step = 5
baseline_samples = 60
"""


def short_study(depths_mm, travel_mm: float = 10.0, slide: str = "") -> str:
    """A study config (TOML) at these depths (mm), the slide ``travel_mm`` long and centred on
    first contact; ``slide`` adds [trials] lines (e.g. a slower speed)."""
    return (f"[trials]\ndepths_mm = {[float(d) for d in depths_mm]}\n{slide}"
            f"travel_mm = {float(travel_mm)}\nslide_start_mm = {-float(travel_mm) / 2}\n"
            + FAST_OFF_THE_SLIDE)
