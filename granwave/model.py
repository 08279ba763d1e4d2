"""In-memory objects that the stages exchange (one per file schema).

Library functions take and return these; only :mod:`granwave.io.files`
turns them into HDF5 files and back. Units are those of docs/method.md §1.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from .contact_models import options as CO
from .errors import InputError

#: The walls' indices where a contact's second grain j would be (contacts/j in the files).
BOTTOM_WALL = -1
TOP_WALL = -2

#: The kicks of ``propagate --source`` (docs/method.md §8): the bottom wall moved along the
#: vertical (compressional, the default) or along x (shear); the detector reads the top wall's
#: force along the same direction.
SOURCE_KINDS = ("normal", "shear")


def check_source_kind(kind: str) -> str:
    kind = str(kind).lower()
    if kind not in SOURCE_KINDS:
        raise InputError(f"source must be one of {', '.join(SOURCE_KINDS)} (got {kind!r})")
    return kind


def no_shear_message(attrs: dict) -> str:
    """The one line that refuses a shear kick on a frictionless system."""
    return (f"no shear source: the packing is frictionless (friction = {float(attrs.get('friction', 0.0)):g}), "
            "so its wall contacts have no tangential stiffness and a wall moved along x does not "
            "couple to the grains; use a frictional packing")


@dataclass
@CO.with_fields([(name, "np.ndarray | None", None) for name in CO.history_datasets()])
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
    # then, per contact sub-model kind with a history (granwave.contact_models.options.history_datasets),
    # its (M, dim) history, e.g. ``rolling_displacement``; None without the sub-model

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
    # The shear kick (docs/method.md §8, "Shear source"): bottom wall moved along x, the top
    # wall's force along x; None for a frictionless packing (no tangential wall coupling).
    shear_source_velocity: np.ndarray | None = None  # IC A initial velocity (n,)
    shear_detector: np.ndarray | None = None  # F_sig = shear_detector @ u (n,)

    @property
    def n_dof(self) -> int:
        return int(self.mass.shape[0])

    def for_source(self, kind: str) -> "LinearSystem":
        """This system with the source and detector of ``kind`` ("normal" or "shear") in the
        places of the normal ones, ``attrs['source_kind']`` set. The shear kick has initial
        condition A only (``source_displacement`` is NaN) and needs friction."""
        kind = check_source_kind(kind)
        if kind == "normal":
            return replace(self, attrs={**self.attrs, "source_kind": kind})
        if self.shear_source_velocity is None or self.shear_detector is None:
            if float(self.attrs.get("friction", 0.0)) == 0.0:
                raise InputError(no_shear_message(self.attrs))
            raise InputError(f"no shear source: this frictional system (friction = "
                             f"{float(self.attrs['friction']):g}) holds no shear source and detector (a "
                             "linear file without its shear group: written before the shear kick, or "
                             "edited); run linearize again on its packing")
        return replace(self, source_velocity=self.shear_source_velocity,
                       source_displacement=np.full(self.n_dof, np.nan), detector=self.shear_detector,
                       attrs={**self.attrs, "source_kind": kind})

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
    shear_amplitude_A: np.ndarray | None = None  # a_n of the shear kick (IC A) (n,)
    shear_coupling: np.ndarray | None = None  # b_n = shear_detector . phi_n (n,)

    def for_source(self, kind: str) -> "Modes":
        """These modes with the projections of ``kind`` ("normal" or "shear") in the places of
        the normal ones (as :meth:`LinearSystem.for_source`)."""
        kind = check_source_kind(kind)
        if kind == "normal":
            return replace(self, attrs={**self.attrs, "source_kind": kind})
        if self.shear_amplitude_A is None or self.shear_coupling is None:
            if float(self.attrs.get("friction", 0.0)) == 0.0:
                raise InputError(no_shear_message(self.attrs))
            raise InputError("these modes hold no shear projections (a modes file from before the "
                             "shear kick): run eigensolve again on the linear file")
        return replace(self, amplitude_A=self.shear_amplitude_A,
                       amplitude_B=np.full(len(self.omega2), np.nan), coupling=self.shear_coupling,
                       attrs={**self.attrs, "source_kind": kind,
                              "zero_mode_drift_A": self.attrs.get("shear_zero_mode_drift_A", 0.0)})

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
    # DEM pulses (granwave.dem.pulse): the pulse field by height bin, a dict of height (B,),
    # count (B,), velocity (B, T), force_max (B,), force_initial (B,), arrival (B,) and the contact
    # counts so far opened, formed, sliding_new (T,) (absent from files before signal schema 1.4)
    pulse: dict | None = None

    @property
    def height(self) -> float:
        return float(self.attrs["height"])
