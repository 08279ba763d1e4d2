"""JSON keys renamed so that each symbol names one quantity (docs/decisions/0038-one-symbol-per-quantity.md).

Until granwave 1.x the width exponent of ``analyze heights`` (W ∝ L^χ) was written ``alpha``, the
letter of the attenuation α(ω), and the pressure exponents of ``pressure-sweep`` (c ∝ p^κ)
``alpha_*``. Writers now write the new keys only; readers take files of either age through
:func:`current_keys`, which fills a missing new key from its old name (the alias period: old
files keep working, nothing is written twice).
"""

from __future__ import annotations

from collections.abc import Mapping

#: ``analyze heights --json`` (and the local exponents of ``analyze continuum``): old -> new.
HEIGHTS = {"alpha": "chi", "alpha_err": "chi_err", "alpha_local": "chi_local",
           "alpha_eff": "chi_eff", "alpha_eff_err": "chi_eff_err"}

#: The speeds whose pressure exponents ``pressure-sweep`` fits (key suffixes).
SWEEP_SPEEDS = ("tof", "peak", "zero", "l", "t")

#: ``pressure-sweep --json``: old -> new (``alpha_tof`` -> ``kappa_tof``, with ``_err``, ``_n``).
SWEEP = {f"alpha_{s}{suffix}": f"kappa_{s}{suffix}" for s in SWEEP_SPEEDS for suffix in ("", "_err", "_n")}


def current_keys(obj, renamed: Mapping[str, str]):
    """``obj`` (a JSON object) with every new key of ``renamed`` that it lacks taken from the old
    key (the old one is kept too: the object is read, not rewritten). Lists and non-mappings
    are returned unchanged; nested ``local`` tables (``analyze continuum``) are renamed too."""
    if not isinstance(obj, Mapping):
        return obj
    out = dict(obj)
    for old, new in renamed.items():
        if new not in out and old in out:
            out[new] = out[old]
    if isinstance(out.get("local"), Mapping):
        out["local"] = current_keys(out["local"], renamed)
    return out
