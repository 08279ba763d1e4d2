"""How many packings a quoted number needs: the one rule, and the variance pooled across heights.

The rule (docs/continuum.md "Honest statistics")
------------------------------------------------
* A per-height number (a mean arrival time, an apparent speed, a ratio) is quoted only with
  at least :data:`MIN_PACKINGS` (5) packings behind it.
* A fit over heights (α(ω), c(ω), the approach fit and L*) is quoted only with at least
  :data:`MIN_PACKINGS_FIT` (10) packings at every height it uses.
* Below that the analyses still compute, but :func:`packing_check` says so (``quotable``
  false, a ``warning`` naming the thin heights); the CLI prints the warning and the report
  repeats it beside the number. Nothing refuses silently, nothing passes silently.
* A height with a single packing has no scatter of its own: it takes the scatter pooled over
  the heights with two or more packings (:func:`pooled_variance`, weights n − 1), never zero.
"""

from __future__ import annotations

import numpy as np

MIN_PACKINGS = 5
MIN_PACKINGS_FIT = 10


def packing_check(counts, heights, *, fit: bool) -> dict:
    """The rule of the module docstring for one analysis: ``counts`` packings at ``heights``.

    Returns {"min_packings", "thin_heights", "thin_counts", "quotable", "warning"}; ``fit``
    says whether the numbers are fits over heights (10 packings needed) or per height (5).
    """
    need = MIN_PACKINGS_FIT if fit else MIN_PACKINGS
    counts = [int(n) for n in counts]
    heights = [float(h) for h in heights]
    thin = [(h, n) for h, n in zip(heights, counts) if n < need]
    warning = ""
    if thin:
        listed = ", ".join(f"{h:.4g} d ({n})" for h, n in thin)
        warning = (f"not quotable: {len(thin)} of {len(counts)} heights have fewer than {need} "
                   f"packings{' (the rule for fits over heights)' if fit else ''}: {listed}")
        if any(n < 2 for _, n in thin):
            warning += "; a height with one packing takes the scatter pooled over the others"
    return {"min_packings": need, "thin_heights": [h for h, _ in thin],
            "thin_counts": [n for _, n in thin], "quotable": not thin, "warning": warning}


def pooled_variance(var, dof) -> tuple[np.ndarray, np.ndarray]:
    """Per-height variances ``var`` (heights x ...) with ``dof`` = n − 1 each: rows with no
    degrees of freedom (one packing) or an unknown variance take the average over the others
    weighted by their dof. Returns (variance, pooled) — ``pooled`` marks the rows that borrowed.
    NaN stays where no row has a variance of its own."""
    var = np.array(var, float)
    dof = np.asarray(dof, float)
    shape = (-1,) + (1,) * (var.ndim - 1)
    d = dof.reshape(shape)
    own = (d > 0) & np.isfinite(var)
    with np.errstate(invalid="ignore", divide="ignore"):
        pooled = np.where(own, d * var, 0.0).sum(axis=0) / np.where(own, d, 0.0).sum(axis=0)
    borrowed = ~own
    var = np.where(borrowed, pooled[None, ...] if var.ndim > 1 else pooled, var)
    return var, borrowed
