"""The workflow dry run's check that every scene's record can hold its tallest column's front
(docs/decisions/0048): the arrival at the perfect lattice's speed plus the exact perfect column's
first lobe, refused when the record ends before it (:func:`record_error`), a warning below two
crossings (:func:`record_warning`). Times in d/sqrt(E*/rho)."""

from __future__ import annotations

import math

from .workflow_config import SCENE_KINDS


def _tallest(kind: str, spec: dict) -> tuple[str, float, str]:
    """(size label, lowest pressure, config key) of a scene's tallest column: the one whose
    front arrives last."""
    series = spec.get("series") or {}
    if kind == "lattices":
        return f"r{max(spec['rows'])}", min(spec["pressures"]), "rows"
    if kind == "chains":
        return f"n{max(spec['balls'])}", spec["pressure"], "balls"
    heights = list(spec["heights"]) + list(series.get("heights", []))
    pressures = list(spec["pressures"]) + list(series.get("pressures", [])) if kind == "disordered" \
        else [spec["pressure"]]
    return f"h{max(heights):g}", min(pressures), "height"


#: The first lobe of the exact chain's wall force ends at t0 + ZERO * M^(1/3) l/c after its
#: travel time t0 (M springs wall to wall, spacing l, speed c): the Airy form of docs/method.md
#: §12 has ZERO = |a'_1|/2 for (A) (the first zero of Ai') and |a_1|/2 for (B) (of Ai, the main
#: lobe after the precursor). The exact modal sum ends it later than LOBE_FLOOR x the Airy form
#: for every chain (A: 0.345 at 1 ball, 0.52 from 2 up, -> 1; B: 0.97 from 8 balls up; below 8
#: the (B) pick is the precursor, which ends before t0, from 0.77 t0 at 2 balls up to 0.94 t0
#: at 7): tests/test_fuzz_configs.py checks it.
LOBE_ZERO = {"A": 1.0187929716474710 / 2.0, "B": 2.3381074104597670 / 2.0}
LOBE_FLOOR = {"A": 0.3, "B": 0.9}
#: (B) rows below which the pick may be the precursor: its end is then bounded by
#: PRECURSOR_END x the arrival.
LOBE_B_MIN_ROWS = 8
PRECURSOR_END = 0.75
#: Row spacing of the densest column (the triangular lattice's rows, sqrt(3)/2 d).
ROW_SPACING = math.sqrt(3.0) / 2.0


def first_lobe_time(kind: str, size: str, arrival: float, ic: str) -> float:
    """A lower bound of the time the first lobe lasts after ``arrival`` (the earliest arrival of
    :func:`record_error`) at a column of ``size``: the exact perfect column's (the lattice's rows,
    a chain's springs) at that speed, LOBE_FLOOR x its Airy form. Disordered fronts are broader.
    Negative for (B) below LOBE_B_MIN_ROWS rows: the front rule picks the precursor there."""
    value = float(size[1:])
    if kind == "chains":
        springs, spacing = value + 1.0, 1.0
    elif kind == "lattices":
        springs, spacing = value + 1.0, ROW_SPACING
    else:
        springs, spacing = value / ROW_SPACING + 1.0, ROW_SPACING
    if ic == "B" and springs - 1.0 < LOBE_B_MIN_ROWS:
        return (PRECURSOR_END - 1.0) * arrival  # negative: the precursor ends before the arrival
    step = arrival / (springs if kind == "chains" else (springs - 1.0))  # l / c
    return LOBE_FLOOR[ic] * LOBE_ZERO[ic] * springs ** (1.0 / 3.0) * step


def _record_needs(config: dict):
    """(kind, scene, key, factor, size, p, what, arrival, needed) of every scene's tallest column:
    ``needed`` the shortest record that can hold its front (arrival + first lobe)."""
    from .workflow_support import crossing_time

    for kind in SCENE_KINDS:
        for scene, spec in (config.get(kind) or {}).items():
            own = kind == "continuum" and "t_max_factor" in spec
            factor = float(spec["t_max_factor"] if own else config["t_max_factor"])
            key = f"{kind}.{scene}.t_max_factor" if own else "t_max_factor"
            size, p, what = _tallest(kind, spec)
            arrival = crossing_time(kind, spec, float(p), size)
            ic = spec.get("ic", config.get("ic", "A")) if kind == "chains" else config.get("ic", "A")
            needed = arrival + first_lobe_time(kind, size, arrival, ic)
            yield kind, scene, key, factor, size, p, what, arrival, needed


def record_error(config: dict) -> str | None:
    """One line naming the key if a scene's record ends before the front of its tallest column
    can be whole in it (a dry run accepted it; the jobs then measured no front). The earliest
    arrival is the height over a generous upper bound of the speed: the perfect-lattice speed of
    the scene's law and pressure (the disordered front is slower), a chain's exact wall-to-wall
    time; the front is measured to the end of its first lobe, which lasts at least the exact
    perfect column's (:func:`first_lobe_time`). The record is ``t_max_factor`` crossings at that
    speed, so a factor below 1 never holds it (but on a (B) chain of a few balls, whose precursor
    is its front), and one just above 1 not on a short column."""
    for kind, scene, key, factor, size, p, what, arrival, needed in _record_needs(config):
        if factor * arrival >= needed:
            continue
        speed = ("its exact wall-to-wall time" if kind == "chains" else
                 f"at most the perfect-lattice speed {float(size[1:]) * (math.sqrt(3) / 2 if kind == 'lattices' else 1) / arrival:.4g} d/t")
        at_least = needed / arrival
        return (f"config: {key} = {factor:g}: the record of {kind}.{scene}'s tallest column "
                f"({what} {size[1:]}, p = {float(p):g}) ends at t = {factor * arrival:.4g}, before "
                f"its front can be whole in it: it needs t_max >= {needed:.4g} (arrival not before "
                f"{arrival:.4g}, {speed}, and its first lobe); the factor must be at least "
                f"{math.ceil(at_least * 1000) / 1000:.4g} (fronts are measured with 2 or more)")
    return None


#: Below this factor a disordered or continuum record may end before its front: such fronts run
#: at about half the perfect lattice's speed (docs/shocks.md). A warning, not a refusal: no bound
#: proves it for a packing not yet made.
RECORD_WARN_FACTOR = 2.0


def record_warning(config: dict) -> str | None:
    """One line (a warning) for the first disordered or continuum scene whose record, though it
    can hold a front at the lattice's speed, is shorter than RECORD_WARN_FACTOR crossings."""
    for kind, scene, key, factor, size, p, what, arrival, needed in _record_needs(config):
        if kind in ("disordered", "continuum") and factor < RECORD_WARN_FACTOR:
            return (f"config: warning: {key} = {factor:g}: {kind}.{scene}'s tallest column "
                    f"({what} {size[1:]}, p = {float(p):g}) records to t = {factor * arrival:.4g}; "
                    f"a disordered front at half the lattice's speed needs t_max >= "
                    f"{RECORD_WARN_FACTOR * arrival:.4g} (a factor of {RECORD_WARN_FACTOR:g})")
    return None
