"""The eigen-spectrum and each mode's weight in the signal (docs/method.md §7)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .common import array, need, new_figure, save_figure, scene_title

if TYPE_CHECKING:
    from ..model import Modes


def spectrum(modes: Modes, path, *, ic: str = "A", bins: int = 60, zero_tol: float = 1e-9,
             pdf: bool = False, scene: str | None = None) -> list[Path]:
    """Density of eigenfrequencies ω and each mode's weight a_n b_n in the signal.

    Zero modes (ω² ≤ zero_tol × max ω²) are left out and counted in the title.
    """
    need(ic in ("A", "B"), "ic must be A or B")
    omega2 = array(modes.omega2, "omega2")
    nz = omega2 > zero_tol * max(float(omega2.max()), 1e-300)
    omega = np.sqrt(omega2[nz])
    a = np.asarray(modes.amplitude_A if ic == "A" else modes.amplitude_B, float)[nz]
    w = a * np.asarray(modes.coupling, float)[nz]
    fig = new_figure((9, 7))
    ax1 = fig.add_subplot(2, 1, 1)
    ax2 = fig.add_subplot(2, 1, 2, sharex=ax1)
    ax1.hist(omega, bins=bins, density=True, color="C0", alpha=0.7)
    ax1.set_ylabel(r"density of states $g(\omega)$  [$\bar d/\sqrt{E^*/\rho}$]")
    ax1.set_title(f"{omega.size} modes, {int((~nz).sum())} zero modes left out")
    ax1.set_xlabel(r"$\omega$  [$\sqrt{E^*/\rho}/\bar d$]")
    ml, sl, bl = ax2.stem(omega, w, markerfmt=".", basefmt="k-")
    sl.set_linewidth(0.6)
    ax2.set_xlabel(r"$\omega$  [$\sqrt{E^*/\rho}/\bar d$]")
    ax2.set_ylabel(f"$a_n b_n$ (initial condition {ic})  [$E^*\\bar d^{{\\,2}}$]")
    a = modes.attrs or {}
    fig.suptitle(scene_title("eigen-spectrum and the modes' weights in the signal", scene=scene,
                             pressure=a.get("pressure"), height=a.get("height"), count="one packing"))
    return save_figure(fig, path, pdf=pdf)

