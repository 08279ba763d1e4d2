"""Parameters of the packing preparation protocol (SPEC §3)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from ..errors import InputError

#: Largest accepted time-step safety: 0.6 of the estimated stability limit
#: (granwave.dem.kernels.stable_dt), measured limits being 0.8-1.0 of the estimate.
MAX_SAFETY = 0.06


@dataclass(frozen=True, kw_only=True)
class PrepareParams:
    """Preparation of a disordered packing by piston compression of a granular gas.

    Units of SPEC §1 (mean diameter, grain density, E* = 1).

    dim             2 (centres in a plane) or 3.
    grains          number of grains N >= 1.
    pressure        p, piston force / (L1 x 1 d) in 2D, / (L1 L2) in 3D; in E*.
    friction        Coulomb coefficient mu >= 0 (0: frictionless, no rotations).
    poisson         nu in [0, 0.5): sets k_t/k_n = 2(1-nu)/(2-nu).
    polydispersity  W in [0, 1): diameters uniform in [1-W, 1+W].
    aspect          expected final height / width (> 0); sets the periodic width.
    damping         zeta, contact damping as a fraction of critical, in [0, 1].
    background_damping  b >= 0, the background viscous rate in units of 1/t_i,
                    t_i = sqrt(m_mean / (p d)) the inertial time at the target
                    pressure; the rate is gamma = b / t_i (force -gamma m v,
                    torque -gamma I w on grains, -gamma M v on the piston). It sets
                    the compaction speed (inertial number), hence density and
                    coordination: keep it fixed within a study.
    piston_mass     M in rho d^3; None: the mass of one layer of grains
                    (mean grain mass x L1 in 2D, x L1 L2 in 3D).
    gas_density     initial solid fraction of the gas (area fraction in 2D, volume
                    fraction in 3D); None: 0.50 (2D) or 0.30 (3D).
    tol             convergence threshold on every acceleration (E*/(rho d)), > 0.
    max_steps       step budget; not converged by then is an error.
    seed            random seed (>= 0): same seed, same packing bit for bit.
    safety          time-step safety factor, (0, MAX_SAFETY]: dt = (safety / 0.1) x the
                    estimated stability limit of the explicit step, contact damping
                    and the rotation of the tangential spring included
                    (granwave.dem.kernels.stable_dt); 0.05 is half the limit.
    skin            Verlet skin in d.
    check_every     steps between convergence checks (and time-step updates).
    """

    dim: int = 2
    grains: int = 600
    pressure: float = 1e-4
    friction: float = 0.5
    poisson: float = 0.0
    polydispersity: float = 0.2
    aspect: float = 1.0
    damping: float = 0.5
    background_damping: float = 0.3
    piston_mass: float | None = None
    gas_density: float | None = None
    tol: float = 1e-10
    max_steps: int = 2_000_000
    seed: int = 0
    safety: float = 0.05
    skin: float = 0.25
    check_every: int = 20

    def __post_init__(self):
        for name, value in asdict(self).items():
            if isinstance(value, float) and not math.isfinite(value):
                raise InputError(f"{name} must be a finite number, got {value!r}")
        if self.dim not in (2, 3):
            raise InputError(f"dim must be 2 or 3, got {self.dim}")
        if not isinstance(self.grains, int) or self.grains < 1:
            raise InputError(f"grains must be an integer >= 1, got {self.grains!r}")
        if not self.pressure > 0.0:
            raise InputError(f"pressure must be > 0, got {self.pressure:g}")
        if self.pressure > 0.1:
            raise InputError(f"pressure {self.pressure:g} is beyond the Hertz regime (must be <= 0.1 E*)")
        if not self.friction >= 0.0:
            raise InputError(f"friction must be >= 0, got {self.friction:g}")
        if not 0.0 <= self.poisson < 0.5:
            raise InputError(f"poisson ratio must be in [0, 0.5), got {self.poisson:g}")
        if not 0.0 <= self.polydispersity < 1.0:
            raise InputError(f"polydispersity must be in [0, 1), got {self.polydispersity:g}")
        if not self.aspect > 0.0:
            raise InputError(f"aspect must be > 0, got {self.aspect:g}")
        if not 0.0 <= self.damping <= 1.0:
            raise InputError(f"damping zeta must be in [0, 1], got {self.damping:g}")
        if not self.background_damping >= 0.0:
            raise InputError(f"background damping must be >= 0, got {self.background_damping:g}")
        if self.piston_mass is not None and not self.piston_mass > 0.0:
            raise InputError(f"piston mass must be > 0, got {self.piston_mass:g}")
        if self.gas_density is not None and not 0.0 < self.gas_density < 0.6:
            raise InputError(f"gas density must be in (0, 0.6), got {self.gas_density:g}")
        if not self.tol > 0.0:
            raise InputError(f"tol must be > 0, got {self.tol:g}")
        if self.max_steps < 1:
            raise InputError(f"max_steps must be >= 1, got {self.max_steps}")
        if self.seed < 0:
            raise InputError(f"seed must be >= 0, got {self.seed}")
        if not 0.0 < self.safety <= MAX_SAFETY:
            raise InputError(f"safety must be in (0, {MAX_SAFETY:g}], got {self.safety:g}: dt is "
                             f"safety/0.1 of the estimated stability limit of the explicit step, and "
                             f"the true limit is as low as 0.8 of the estimate (docs/dem.md)")
        if not 0.0 < self.skin <= 1.0:
            raise InputError(f"skin must be in (0, 1], got {self.skin:g}")
        if self.check_every < 1:
            raise InputError(f"check_every must be >= 1, got {self.check_every}")

    def as_attrs(self) -> dict:
        return {k: ("none" if v is None else v) for k, v in asdict(self).items()}
