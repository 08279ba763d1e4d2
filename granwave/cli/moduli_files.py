"""Reading `granwave analyze moduli --json` files for the analyses that compare with them
(`analyze continuum`, `analyze attenuation`, `analyze front` of a shear signal)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from ..errors import InputError

#: the two kinds of c_l, c_t a moduli file gives: the bulk slab's and the whole cell's
SPEED_KEYS = {"slab": ("c_l_slab", "c_t_slab"), "cell": ("c_l", "c_t")}


def _speed(value) -> float:
    """A speed from a moduli file: NaN for null or absent."""
    return float("nan") if value is None else float(value)


#: the numbers of a moduli file the analyses read: each a finite number or null
NUMBERS = ("c_l", "c_t", "c_l_slab", "c_t_slab", "phi3_star", "phi3_star_cell", "phi3_star_slab",
           "C11", "C12", "C22", "C33", "C44", "C55", "C45", "pressure", "friction", "height")


def read_moduli(path, required: str = "c_l") -> dict:
    """The content of one `granwave analyze moduli --json` file; InputError for a file that is not
    one, one without the field ``required``, a ``dim`` other than 2 or 3, or a speed, modulus or
    density that is not a number (a string, a boolean; null is a failed solve)."""
    from ..io.files import load_json

    m = load_json(path)  # an unreadable or malformed file: one line naming it
    if not isinstance(m, dict) or required not in m:
        raise InputError(f"{path}: no {required} (expected `granwave analyze moduli --json` output)")
    dim = m.get("dim", 2)
    if isinstance(dim, bool) or dim not in (2, 3):
        raise InputError(f"{path}: dim {dim!r}: a moduli file is of a 2D or 3D packing")
    for key in NUMBERS:
        v = m.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))
                              or not math.isfinite(v)):
            raise InputError(f"{path}: {key} {v!r} is not a finite number (null where the solve failed)")
    return m


def moduli_mismatch(m: dict, signal, path=None, label=None, warn: bool = True) -> str | None:
    """Why the moduli ``m`` are not of the packing of ``signal``, or None: its packing_digest
    where both record one, else the dimension, pressure, friction, seed and height they record
    (files written before the moduli recorded their packing: the dimension only, with an
    OlderFileWarning naming ``path`` or ``label`` and how to remake the file)."""
    want, got = m.get("packing_digest"), signal.attrs.get("packing_digest")
    if isinstance(want, str) and isinstance(got, str) and want not in ("", "none") and got != "none":
        return None if want == got else f"are of another packing (packing_digest {want}, the signal's {got})"
    for key in ("dim", "pressure", "friction", "seed", "height"):
        a, b = m.get(key), signal.attrs.get("packing_seed" if key == "seed" else key,
                                             signal.attrs.get(key))
        if a is None or b is None or isinstance(b, str):
            continue
        if not math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=0.0):
            return f"have {key} = {a:g}, the signal {float(b):g}"
    if warn:
        _warn_older([older_note(m, signal, path, label)])
    return None


def older_note(m: dict, signal, path=None, label=None) -> str | None:
    """What goes unchecked between the moduli ``m`` and ``signal`` when one of them records no
    packing_digest (an older granwave's file), and how to remake it; None when both record one."""
    want, got = m.get("packing_digest"), signal.attrs.get("packing_digest")
    recorded = ["dim", *(k for k in ("pressure", "friction", "seed", "height") if m.get(k) is not None)]
    if not isinstance(want, str) or want in ("", "none"):
        return (f"{path or 'a moduli file'} records no packing_digest (an older granwave): checked against "
                f"{label or 'the signal'} by {', '.join(recorded)} only; remake it with `granwave analyze "
                "moduli PACKING --json > MODULI.json` to have it checked")
    if not isinstance(got, str) or got in ("", "none"):
        return (f"{label or 'the signal'} records no packing_digest (an older granwave): checked against "
                f"{path or 'its moduli'} by {', '.join(recorded)} only; remake it from its packing "
                "(granwave linearize, then propagate) to have it checked")
    return None


def _warn_older(notes) -> None:
    """One OlderFileWarning for the first note, counting the others."""
    notes = [n for n in notes if n]
    if notes:
        import warnings

        from ..errors import OlderFileWarning

        more = f" (and {len(notes) - 1} more file pairs like it)" if len(notes) > 1 else ""
        warnings.warn(OlderFileWarning(notes[0] + more), stacklevel=3)


def check_moduli_of(paths: Sequence[str], signals, labels: Sequence[str]) -> None:
    """InputError (one line) unless each moduli file is of its signal's packing (same order)."""
    notes = []
    for path, sig, lab in zip(paths, signals, labels):
        m = read_moduli(path)
        why = moduli_mismatch(m, sig, path, lab, warn=False)
        if why is not None:
            raise InputError(f"{path}: the moduli {why}: they are not of {lab}'s packing (give the "
                             "moduli of each signal's packing, in the order of the signals)")
        notes.append(older_note(m, sig, path, lab))
    _warn_older(notes)


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
