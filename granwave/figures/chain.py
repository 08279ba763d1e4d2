"""The 1D chain against its Airy asymptote (docs/method.md §12)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .common import need, new_figure, save_figure, scene_title


def chain_airy(path, *, n_balls: Sequence[int] = (25, 50, 100, 200), ic: str = "A",
               exact: Callable | None = None, airy: Callable | None = None,
               window: float = 12.0, samples: int = 800, pdf: bool = False,
               scene: str | None = None) -> list[Path]:
    """Chain wall force (exact modal sum) against the Airy asymptote, co-moving frame.

    Units of the chain: ℓ = 1, c = 1 (so t0 = N + 1). The x axis is
    s = 2τ / N^{1/3} with τ = t − t0; the force is scaled by N^{2/3} (A) or N (B),
    so the curves of every N collapse on the Airy shape for large N.

    ``exact(t, n_balls, ic)`` and ``airy(t, n_balls, ic)`` return the force on
    the far wall at times t > 0; by default :func:`granwave.theory.chain_wall_force`
    and :func:`granwave.theory.chain_wall_force_airy` (K = m = ℓ = 1).
    """
    need(ic in ("A", "B"), "ic must be A or B")
    n_balls = [int(n) for n in n_balls]
    need(len(n_balls) > 0 and min(n_balls) >= 2, "give chain lengths of at least 2 balls")
    own_sum = exact is None  # granwave.theory's modal sum: its cost is known
    if exact is None or airy is None:
        e2, a2 = _theory_chain()
        exact, airy = exact or e2, airy or a2
    if own_sum:  # the modal sum's memory and time, refused before any array is allocated
        from ..resources import check_chain_force, check_run_time

        seconds = sum(check_chain_force(N, samples) for N in n_balls)
        check_run_time(seconds, f"the exact wall force of chains of {', '.join(map(str, n_balls))} balls "
                                f"at {samples} times")
    power = 2 / 3 if ic == "A" else 1.0
    fig = new_figure((12, 5))
    ax1, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    import matplotlib as mpl
    cmap = mpl.colormaps["plasma"]
    for k, N in enumerate(sorted(n_balls)):
        col = cmap(0.85 * k / max(len(n_balls) - 1, 1))
        t0 = N + 1.0
        half = window * N ** (1 / 3) / 2
        t = np.linspace(max(t0 - 2 * half, 0.5), t0 + half, samples)
        F = np.asarray(exact(t, N, ic), float)
        s = 2 * (t - t0) / N ** (1 / 3)
        ax1.plot(t, F, color=col, lw=1, label=f"N = {N}")
        ax2.plot(s, F * N ** power, color=col, lw=1.3, label=f"exact, N = {N}")
        if airy is not None:
            ax2.plot(s, np.asarray(airy(t, N, ic), float) * N ** power, "--", color=col, lw=0.9)
    if airy is not None:
        ax2.plot([], [], "k--", lw=0.9, label="Airy asymptote")
    ax1.set_xlabel(r"time $t$  [$\ell/c$]")
    ax1.set_ylabel(r"wall force $F$  [$K\ell$]")
    ax1.set_title(f"initial condition {ic}: exact modal sum")
    ax2.set_xlabel(r"$2(t-t_0)c/(\ell N^{1/3})$  [1],  $t_0 = (N+1)\ell/c$")
    ax2.set_ylabel(f"$F\\,N^{{{'2/3' if ic == 'A' else '1'}}}$  [$K\\ell$]")
    fig.suptitle(scene_title(f"1D chain of N = {', '.join(map(str, sorted(n_balls)))} identical balls "
                             "against the Airy asymptote (springs K, spacing ℓ, ball mass m, c = ℓ√(K/m); "
                             "docs/method.md §12)", scene=scene), fontsize=9)
    ax2.set_title("co-moving frame")
    ax2.set_xlim(-window, window / 2)
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    return save_figure(fig, path, pdf=pdf)


def _theory_chain():
    from ..theory import chain_wall_force, chain_wall_force_airy

    return (lambda t, n, ic: chain_wall_force(t, n, ic=ic),
            lambda t, n, ic: chain_wall_force_airy(t, n, ic=ic))

