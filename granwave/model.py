"""In-memory objects that the stages exchange (one per file schema).

Library functions take and return these; only :mod:`granwave.io.files`
turns them into HDF5 files and back. Units are those of docs/method.md §1.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .io.schema import BOTTOM_WALL, TOP_WALL


@dataclass
class Contacts:
    """Force-carrying contacts (M rows). ``j`` = -1 bottom wall, -2 top wall."""

    i: np.ndarray
    j: np.ndarray
    normal: np.ndarray  # (M, dim), unit vector from i towards j
    overlap: np.ndarray  # (M,)
    force_normal: np.ndarray  # (M,), magnitude; force on i is -force_normal * normal
    force_tangential: np.ndarray  # (M, dim), force on i from j
    stiffness_normal: np.ndarray  # (M,)
    stiffness_tangential: np.ndarray  # (M,)

    def __len__(self) -> int:
        return len(self.i)

    @property
    def is_wall(self) -> np.ndarray:
        return self.j < 0

    @property
    def is_bottom(self) -> np.ndarray:
        return self.j == BOTTOM_WALL

    @property
    def is_top(self) -> np.ndarray:
        return self.j == TOP_WALL

    @classmethod
    def empty(cls, dim: int) -> "Contacts":
        z = np.zeros(0)
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, dim)), z, z.copy(),
                   np.zeros((0, dim)), z.copy(), z.copy())


@dataclass
class Packing:
    """A packing in mechanical equilibrium (or a chain / lattice state).

    ``box`` holds the periodic lengths and, last, the bottom-wall-to-top-wall
    distance; the bottom wall sits at 0 along the last axis. ``attrs`` holds
    the root attributes: at least ``dim, pressure, friction, poisson, seed,
    converged, max_acceleration, kind`` plus the protocol parameters.
    """

    position: np.ndarray  # (N, dim)
    radius: np.ndarray  # (N,)
    mass: np.ndarray  # (N,)
    inertia: np.ndarray  # (N,)
    box: np.ndarray  # (dim,)
    contacts: Contacts
    attrs: dict = field(default_factory=dict)

    @property
    def dim(self) -> int:
        return int(self.position.shape[1])

    @property
    def n_grains(self) -> int:
        return int(self.position.shape[0])

    @property
    def height(self) -> float:
        """Source-detector distance: bottom wall to top wall."""
        return float(self.box[-1])

    @property
    def pressure(self) -> float:
        return float(self.attrs["pressure"])

    def require_finite(self) -> None:
        """Raise InputError naming the first array with NaN or infinite values."""
        from .errors import InputError

        for name in ("position", "radius", "mass", "inertia", "box"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise InputError(f"packing {name} contains NaN or infinite values")
        for name in ("normal", "overlap", "force_normal", "force_tangential",
                     "stiffness_normal", "stiffness_tangential"):
            if not np.all(np.isfinite(getattr(self.contacts, name))):
                raise InputError(f"packing contacts/{name} contains NaN or infinite values")

    @property
    def friction(self) -> float:
        return float(self.attrs["friction"])


@dataclass
class LinearSystem:
    """M u'' = -D u around equilibrium (docs/method.md §5), with source and detector vectors."""

    stiffness: sp.csr_matrix  # D (n, n), symmetric positive semi-definite
    mass: np.ndarray  # diagonal of M (n,)
    dof_grain: np.ndarray  # (n,) grain index of each dof
    dof_axis: np.ndarray  # (n,) 0..dim-1 translation, dim.. rotation
    source_velocity: np.ndarray  # IC A initial velocity (n,)
    source_displacement: np.ndarray  # IC B initial displacement (n,)
    detector: np.ndarray  # F_sig = detector @ u (n,)
    attrs: dict = field(default_factory=dict)

    @property
    def n_dof(self) -> int:
        return int(self.mass.shape[0])

    @property
    def height(self) -> float:
        return float(self.attrs["height"])


@dataclass
class Modes:
    """Spectrum of D phi = omega^2 M phi and each mode's part in the signal (docs/method.md §7)."""

    omega2: np.ndarray  # ascending (n,)
    amplitude_A: np.ndarray  # (n,)
    amplitude_B: np.ndarray  # (n,)
    coupling: np.ndarray  # b_n (n,)
    vectors: np.ndarray | None = None  # (n, n) columns, M-orthonormal, optional
    attrs: dict = field(default_factory=dict)

    @property
    def height(self) -> float:
        return float(self.attrs["height"])


@dataclass
class Signal:
    """Force on the detector wall against time (docs/method.md §8)."""

    time: np.ndarray
    force: np.ndarray
    attrs: dict = field(default_factory=dict)  # ic, method, height, ...
    snapshot_time: np.ndarray | None = None
    snapshot_displacement: np.ndarray | None = None  # (S, n)
    dof_grain: np.ndarray | None = None
    dof_axis: np.ndarray | None = None
    position: np.ndarray | None = None  # (N, dim) equilibrium positions

    @property
    def height(self) -> float:
        return float(self.attrs["height"])
