"""How the report writes numbers: one rule for every table and sentence.

* **value ± error** (:func:`fmt`): the error to one significant digit, two
  when its leading digit is 1 (0.013, 0.2, 130); the value rounded to the
  same decimal place (0.81 ± 0.02, not 0.8123 ± 0.02). When the larger of
  |value| and error is ≥ 1e5 or < 1e-3 both share one power of ten:
  ``(-4 ± 6)e-04``. A value without an error (a theory value, one
  deterministic system) keeps ``digits`` significant digits.
* **value [95 % interval]** (:func:`fmt_ci`): the value and both ends rounded as
  ``value ± error`` rounds them (the error's decimal place, one shared power of ten
  outside [1e-3, 1e5)): ``3.8 [2.9, 4.7]``, ``(5.12 [5.04, 5.20])e-05``.
* **counts** (:func:`fmt_count`): integers, never 1.17e+03.
* **ranges** (:func:`fmt_range`): min … max with as many digits as it takes
  to tell them apart; integers as integers.
* **positive quantities** (:func:`fmt_positive`): an attenuation, a quality
  factor, a length scale or a ratio of speeds cannot be negative. When its
  95 % interval (given, or value ± 2 errors) reaches zero or below, the
  estimate is not shown: an upper bound "< hi (95 %; consistent with 0)" or
  "not resolved". When the interval spans more than a decade the estimate is
  not shown either, only the interval "[lo, hi] (95 %)".

Missing or non-finite numbers are "—".
"""

from __future__ import annotations

import math

MISSING = "—"
SCI_HIGH, SCI_LOW = 1e5, 1e-3   # outside [SCI_LOW, SCI_HIGH): one shared power of ten
MAX_DIGITS = 6                  # a value is never shown with more significant digits
DECADE = 10.0                   # a 95 % interval wider than this factor is a bound


def num(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _exp10(x: float) -> int:
    """The decade of |x| (x ≠ 0), robust to 9.999… rounding."""
    return int(f"{abs(x):.0e}".split("e")[1]) if x else 0


def _error_digits(e: float) -> tuple[float, int]:
    """(error rounded, decimal exponent of its last shown digit): 2 digits if it starts with 1."""
    two = f"{e:.1e}"                       # "1.3e+02", "2.1e-02"
    s = two if two.startswith("1") else f"{e:.0e}"
    mant, ex = s.split("e")
    q = int(ex) - (len(mant.replace(".", "")) - 1)
    return float(s), q


def _fixed(x: float, decimals: int) -> str:
    s = f"{x:.{max(decimals, 0)}f}"
    return s[1:] if s.startswith("-") and float(s) == 0 else s


def fmt(x, err=None, digits: int = 4) -> str:
    """``value ± error`` by the module's rule; the value alone with ``digits`` digits when
    the error is missing, zero or not finite; "—" for a missing value."""
    x = num(x)
    if not math.isfinite(x):
        return MISSING
    e = num(err)
    if err is None or not math.isfinite(e) or e <= 0:
        return f"{x:.{digits}g}"
    er, q = _error_digits(e)
    if x and _exp10(x) - q + 1 > MAX_DIGITS:  # an error far below the value's shown digits
        return f"{x:.{MAX_DIGITS}g} ± {er:.2g}"
    xr = round(x, -q) + 0.0                # + 0.0: no "-0"
    big = max(abs(xr), er)
    if big >= SCI_HIGH or big < SCI_LOW:
        E = _exp10(big)
        d = E - q
        return f"({_fixed(xr / 10 ** E, d)} ± {_fixed(er / 10 ** E, d)})e{E:+03d}"
    return f"{_fixed(xr, -q)} ± {_fixed(er, -q)}"


def fmt_ci(x, err, lo, hi, digits: int = 4) -> str:
    """``value [lo, hi]``: a value and its 95 % interval, rounded at the decimal place of
    ``err`` (its standard error) as :func:`fmt` rounds; :func:`fmt` when an end or the error is
    missing."""
    x, e, lo, hi = num(x), num(err), num(lo), num(hi)
    if not (math.isfinite(x) and math.isfinite(e) and e > 0 and math.isfinite(lo) and math.isfinite(hi)):
        return fmt(x, err, digits)
    _, q = _error_digits(e)
    if x and _exp10(x) - q + 1 > MAX_DIGITS:
        q = _exp10(x) - MAX_DIGITS + 1
    xr, lr, hr = (round(v, -q) + 0.0 for v in (x, lo, hi))
    big = max(abs(xr), abs(lr), abs(hr))
    if big >= SCI_HIGH or big < SCI_LOW:
        E = _exp10(big)
        d = E - q
        return f"({_fixed(xr / 10 ** E, d)} [{_fixed(lr / 10 ** E, d)}, {_fixed(hr / 10 ** E, d)}])e{E:+03d}"
    return f"{_fixed(xr, -q)} [{_fixed(lr, -q)}, {_fixed(hr, -q)}]"


def fmt_count(x) -> str:
    """A count: an integer ("1168"), "—" when missing."""
    v = num(x)
    return str(int(round(v))) if math.isfinite(v) else MISSING


def fmt_range(lo, hi, digits: int = 3) -> str:
    """``lo … hi``: integers as integers, else as few digits (≥ ``digits``) as tell them apart."""
    lo, hi = num(lo), num(hi)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return MISSING
    if lo == int(lo) and hi == int(hi) and max(abs(lo), abs(hi)) < 1e15:
        return f"{int(lo)} … {int(hi)}"
    for d in range(digits, 17):
        a, b = f"{lo:.{d}g}", f"{hi:.{d}g}"
        if a != b or lo == hi:
            return f"{a} … {b}"
    return f"{lo!r} … {hi!r}"


def fmt_bound(x, digits: int = 2) -> str:
    """A bound or an interval end: ``digits`` significant digits, plain notation inside
    [1e-3, 1e5) (170, 0.00078), else like 4e+07."""
    x = num(x)
    if not math.isfinite(x):
        return MISSING
    if x == 0:
        return "0"
    r = float(f"{x:.{digits - 1}e}")
    if SCI_LOW <= abs(r) < SCI_HIGH:
        return _fixed(r, digits - 1 - _exp10(r))
    return f"{r:.{digits - 1}e}"


def interval95(x, err=None, ci=None) -> tuple[float, float]:
    """The 95 % interval: ``ci`` when both ends are finite, else value ± 2 errors."""
    if ci is not None and len(ci) == 2 and all(math.isfinite(num(v)) for v in ci):
        return num(ci[0]), num(ci[1])
    x, e = num(x), num(err)
    if math.isfinite(x) and math.isfinite(e) and e > 0:
        return x - 2 * e, x + 2 * e
    return math.nan, math.nan


def resolved(x, err=None, ci=None) -> bool:
    """Whether a positive quantity's estimate can be shown as one: positive, its 95 % interval
    above zero and within a decade."""
    x = num(x)
    lo, hi = interval95(x, err, ci)
    if not math.isfinite(x) or x <= 0:
        return False
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return True                        # no error known: the value as it is
    return lo > 0 and hi <= DECADE * lo


def fmt_positive(x, err=None, ci=None, *, digits: int = 4, show_ci: bool = False) -> str:
    """A physically positive quantity (rule: module docstring). ``ci``: its 95 % interval,
    else value ± 2 errors stands for one; ``show_ci``: add "(95 % lo … hi)" to an estimate."""
    x = num(x)
    if not math.isfinite(x):
        return MISSING
    lo, hi = interval95(x, err, ci)
    if resolved(x, err, ci):
        s = fmt(x, err, digits)
        if show_ci and math.isfinite(lo):
            s += f" (95 % {fmt_bound(lo)} … {fmt_bound(hi)})"
        return s
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "not resolved (≤ 0)"
    if hi <= 0:
        return "not resolved (95 % interval ≤ 0)"
    if lo <= 0:
        return f"< {fmt_bound(hi)} (95 %; consistent with 0)"
    return f"[{fmt_bound(lo)}, {fmt_bound(hi)}] (95 %)"  # over a decade: the interval, no estimate


def fmt_named(name: str, text: str) -> str:
    """``name = estimate``, ``name < bound``, ``name ∈ [lo, hi] (95 %)`` or ``name not resolved``
    for the strings of :func:`fmt_positive`."""
    if text.startswith(("<", ">")):
        return f"{name} {text}"
    if text.startswith("["):
        return f"{name} ∈ {text}"
    if text.startswith("not"):
        return f"{name} {text}"
    return f"{name} = {text}"
