"""Reading `granwave analyze moduli --json` files for the analyses that compare with them
(`analyze continuum`, `analyze attenuation`, `analyze front` of a shear signal)."""

from __future__ import annotations

import json
from collections.abc import Sequence

from ..errors import InputError

#: the two kinds of c_l, c_t a moduli file gives: the bulk slab's and the whole cell's
SPEED_KEYS = {"slab": ("c_l_slab", "c_t_slab"), "cell": ("c_l", "c_t")}


def _speed(value) -> float:
    """A speed from a moduli file: NaN for null or absent."""
    return float("nan") if value is None else float(value)


def read_moduli(path, required: str = "c_l") -> dict:
    """The content of one `granwave analyze moduli --json` file; InputError for a file that is not
    one, or one without the field ``required``."""
    try:
        with open(path) as f:
            m = json.load(f)
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not a moduli JSON file ({exc})") from None
    if not isinstance(m, dict) or required not in m:
        raise InputError(f"{path}: no {required} (expected `granwave analyze moduli --json` output)")
    return m


def moduli_speeds(paths: Sequence[str], kind: str = "slab") -> dict[str, tuple[list, list]]:
    """{kind: ([c_l], [c_t])} of every file, both kinds (sqrt(E*/rho); NaN where a batch's
    moduli solve failed). InputError for a file that is not a moduli JSON, or one without the
    bulk slab's speeds when ``kind`` is "slab" (written before them)."""
    speeds = {k: ([], []) for k in SPEED_KEYS}
    for path in paths:
        m = read_moduli(path)
        failed = m["c_l"] is None  # a batch's failed moduli solve: no speed of either kind
        if kind == "slab" and "c_l_slab" not in m and not failed:
            raise InputError(f"{path}: no c_l_slab (written before the bulk-slab moduli): run "
                             "`granwave analyze moduli --json` again, or pass --c-l cell")
        for k, (kl, kt) in SPEED_KEYS.items():
            speeds[k][0].append(_speed(m.get(kl)))
            speeds[k][1].append(_speed(m.get(kt)))
    return speeds
