"""Exact references the report and the figures compare with: the identical-ball chain."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import InputError


def chain_series(n_balls: Sequence[int], *, ic: str = "A") -> dict:
    """Front features of the exact identical-ball chain (theory) against L = N + 1.

    Units of the chain: ℓ = K = m = 1 (c = 1); L = N + 1 is the wall-to-wall
    distance. Each signal is the exact modal sum sampled 20 times per unit
    time from 0 to t0 + 10 N^{1/3}.
    """
    from ..analysis.front import front_features
    from ..theory import chain_wall_force

    ns = sorted({int(n) for n in n_balls})
    if not ns or ns[0] < 2:
        raise InputError("chain lengths must be at least 2")
    rows = []
    for n in ns:
        t = np.arange(0.0, n + 1 + 10 * n ** (1 / 3), 0.05)
        rows.append(front_features(t, chain_wall_force(t, n, ic=ic)).as_dict())
    out = {"height": np.array([n + 1.0 for n in ns])}
    for k in ("t_lead10", "t_peak", "t_zero", "amplitude", "width"):
        out[k] = np.array([r[k] for r in rows])
    return out


def chain_exact_exponents(ic: str = "A", *, n_balls: tuple[int, int] = (10**6, 8 * 10**6)) -> dict:
    """γ and χ (key ``chi``, W ∝ L^χ) of the chain from the Airy asymptote (docs/method.md §12).

    The front features of :func:`granwave.theory.chain_wall_force_airy` at two
    very large N give d log A / d log L and d log W / d log L; the corrections
    are of relative order N^{-1/3}·(1/N) and vanish at the digits shown.
    """
    from ..analysis.front import front_features
    from ..theory import chain_wall_force_airy

    feats = []
    for n in n_balls:
        w = n ** (1 / 3)
        t = (n + 1) + np.linspace(-15 * w, 15 * w, 6001)
        feats.append(front_features(t, chain_wall_force_airy(t, n, ic=ic)))
    lr = math.log((n_balls[1] + 1) / (n_balls[0] + 1))
    return {"gamma": -math.log(feats[1].amplitude / feats[0].amplitude) / lr,
            "chi": math.log(feats[1].width / feats[0].width) / lr}
