"""What an estimator is worth: its validated bias and coverage from the truth suite.

The truth suite (its runner in the benchmarks folder, its table in the docs) runs every
estimator the report quotes through the functions and defaults the scenes use, on inputs with
a known answer, and writes the current table into the package's data folder
(:data:`TRUTH_FILE`)::

    {"revision": ..., "date": ...,
     "estimators": {key: [{"setting", "truth", "n_seeds", "bias", "bias_rel", "bias_err",
                           "coverage95", "verdict"}, ...]}}

with ``verdict`` one of "validated", "biased", "undercovered" and ``coverage95`` null where
the estimator quotes no interval. :func:`estimator_check` reads one key (the first of several
names that the table holds: keys renamed keep their old name as an alias) and
:func:`check_cell` writes it as a report cell; a key the table lacks, or no table at all, is
"not validated" — never a number typed in.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from .numbers import MISSING, fmt, num

#: The truth suite's table shipped with the package.
TRUTH_FILE = Path(__file__).resolve().parents[1] / "data" / "truth.json"

NOT_VALIDATED = "not validated"


@functools.lru_cache(maxsize=8)
def _load(path: str) -> Mapping | None:
    try:
        obj = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return obj if isinstance(obj, Mapping) and isinstance(obj.get("estimators"), Mapping) else None


def truth_table(path: str | Path | None = None) -> Mapping | None:
    """The truth suite's table (``path``, default :data:`TRUTH_FILE`), or None when it is
    missing or unreadable."""
    return _load(str(path or TRUTH_FILE))


def estimator_check(keys: str | Sequence[str], *, path: str | Path | None = None) -> dict | None:
    """The truth-suite record of the first of ``keys`` the table holds, summarised over its
    settings: ``key``, ``settings`` (how many), ``verdict`` (the worst: "biased" or
    "undercovered" beats "validated"), ``bias_rel`` and ``bias_rel_err`` of the setting with the
    largest |relative bias|, ``coverage95`` (the smallest over the settings that quote an
    interval, else None), ``n_seeds`` (the smallest), ``revision``. None: not validated."""
    table = truth_table(path)
    if table is None:
        return None
    for key in ([keys] if isinstance(keys, str) else list(keys)):
        rows = [r for r in (table["estimators"].get(key) or []) if isinstance(r, Mapping)]
        if rows:
            return _summary(key, rows, table)
    return None


def _summary(key: str, rows: Sequence[Mapping], table: Mapping) -> dict:
    verdicts = [str(r.get("verdict", "")) for r in rows]
    worst = next((v for v in ("biased", "undercovered") if v in verdicts),
                 "validated" if all(v == "validated" for v in verdicts) else "unknown")

    def rel(r):
        b = num(r.get("bias_rel"))
        return abs(b) if math.isfinite(b) else -1.0

    big = max(rows, key=rel)
    covs = [num(r.get("coverage95")) for r in rows if r.get("coverage95") is not None]
    covs = [c for c in covs if math.isfinite(c)]
    seeds = [num(r.get("n_seeds")) for r in rows if math.isfinite(num(r.get("n_seeds")))]
    rel_err = num(big.get("bias_err")) / abs(num(big.get("truth"))) \
        if num(big.get("truth")) else math.nan
    return {"key": key, "settings": len(rows), "verdict": worst,
            "bias_rel": num(big.get("bias_rel")), "bias_rel_err": rel_err,
            "setting": big.get("setting"), "coverage95": min(covs) if covs else None,
            "n_seeds": int(min(seeds)) if seeds else None, "revision": table.get("revision")}


def check_cell(keys: str | Sequence[str] | None, *, path: str | Path | None = None) -> str:
    """A findings-table cell: "validated: bias +0.3 ± 0.2 %, 95 % coverage 0.94 (3 settings)",
    "biased: ..." / "undercovered: ...", or "not validated" (no table, or no such key);
    "—" for a row with no estimator (``keys`` None)."""
    if keys is None:
        return MISSING
    rec = estimator_check(keys, path=path)
    if rec is None:
        return NOT_VALIDATED
    parts = []
    if math.isfinite(rec["bias_rel"]):
        err = rec["bias_rel_err"] * 100 if math.isfinite(rec["bias_rel_err"]) else None
        parts.append(f"bias {fmt(rec['bias_rel'] * 100, err, 2)} %")
    if rec["coverage95"] is not None:
        parts.append(f"95 % coverage {rec['coverage95']:.2f}")
    where = f"{rec['settings']} setting{'s' if rec['settings'] != 1 else ''}"
    if rec["n_seeds"]:
        where += f", ≥ {rec['n_seeds']} seeds"
    return f"{rec['verdict']}: {', '.join(parts) or 'no bias recorded'} ({where}; `{rec['key']}`)"
