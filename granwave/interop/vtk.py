"""ParaView (VTK XML) files of packings and of signal snapshots, written with meshio.

Packing (:func:`packing_mesh`, one ``.vtu``): every grain is a point (a ``vertex``
cell) with point data ``radius`` (d_bar), ``mass`` (rho d_bar^3), ``rattler`` (1 for
grains without force-carrying contacts, :func:`granwave.analysis.statics.find_rattlers`
with its defaults) and ``kind`` (0 grain, 1 contact point on a wall, 2 periodic image
of a grain). Every force-carrying contact is a ``line`` cell from grain i to j — to
j's nearest periodic image when the contact crosses the periodic boundary (an
extra point of kind 2), to the contact point on the wall for wall contacts (kind
1) — with cell data ``force_normal`` (E_star d_bar^2, magnitude), ``force_tangential``
(vector on i from j), ``normal`` (unit, i towards j), ``overlap`` and ``j`` (-1
bottom wall, -2 piston). Vertex cells carry 0 for the contact data. Points are
3D (z = 0 in 2D). In ParaView: Glyph (sphere, scale by radius x 2) on the points,
Tube on the lines coloured by force_normal.

Signal snapshots (:func:`write_snapshot_series`): one ``.vtu`` per snapshot time
(grains as points with ``displacement`` (d_bar) and, when present, ``rotation``
(radians)) and a ``.pvd`` collection giving each file its time, which ParaView
opens as a time series.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.files import atomic_file, atomic_text, check_writable
from ..model import Packing, Signal


def _meshio():
    try:
        import meshio
    except ImportError:  # an optional dependency: say how to get it
        raise InputError("VTK export needs meshio: pip install 'granwave[interop]'") from None
    return meshio


def _points3(position: np.ndarray) -> np.ndarray:
    pts = np.zeros((position.shape[0], 3))
    pts[:, : position.shape[1]] = position
    return pts


def packing_mesh(packing: Packing):
    """A meshio Mesh of the packing (module docstring)."""
    from ..analysis.statics import find_rattlers

    meshio = _meshio()
    n, d = packing.n_grains, packing.dim
    c = packing.contacts
    lateral = packing.box[:-1]
    extra_pts, extra_kind = [], []
    ends = np.zeros(len(c), np.int64)
    for k in range(len(c)):
        i, j = int(c.i[k]), int(c.j[k])
        if j >= 0:
            delta = packing.position[j] - packing.position[i]
            shift = np.zeros(d)
            shift[:-1] = -lateral * np.round(delta[:-1] / lateral)
            if not np.any(shift):
                ends[k] = j
                continue
            extra_pts.append(packing.position[j] + shift)
            extra_kind.append(2)
        else:  # the contact point on the wall, below or above the grain
            p = packing.position[i].copy()
            p[-1] = 0.0 if j == -1 else packing.height
            extra_pts.append(p)
            extra_kind.append(1)
        ends[k] = n + len(extra_pts) - 1
    pos = packing.position if not extra_pts else np.vstack([packing.position, np.array(extra_pts)])
    m = len(extra_pts)
    rattler, _ = find_rattlers(packing)
    kind = np.concatenate([np.zeros(n, np.int32), np.array(extra_kind, np.int32)])
    point_data = {
        "radius": np.concatenate([packing.radius, np.zeros(m)]),
        "mass": np.concatenate([packing.mass, np.zeros(m)]),
        "rattler": np.concatenate([rattler.astype(np.int32), np.zeros(m, np.int32)]),
        "kind": kind,
    }
    cells = [("vertex", np.arange(n, dtype=np.int64)[:, None])]
    zeros = lambda *shape: np.zeros((n, *shape))  # noqa: E731
    cell_data = {"force_normal": [zeros(), c.force_normal.astype(float)],
                 "force_tangential": [zeros(3), _points3(c.force_tangential)],
                 "normal": [zeros(3), _points3(c.normal)],
                 "overlap": [zeros(), c.overlap.astype(float)],
                 "j": [np.zeros(n, np.int64), c.j.astype(np.int64)]}
    if len(c):
        cells.append(("line", np.column_stack([c.i.astype(np.int64), ends])))
    else:
        cell_data = {key: value[:1] for key, value in cell_data.items()}
    return meshio.Mesh(_points3(pos), cells, point_data=point_data, cell_data=cell_data)


def write_packing_vtu(path, packing: Packing) -> Path:
    """Write the packing as one ``.vtu`` (atomically)."""
    meshio = _meshio()
    path = Path(path)
    if path.suffix != ".vtu":
        raise InputError(f"{path}: a packing is written as a .vtu file")
    mesh = packing_mesh(packing)
    with atomic_file(path, suffix=".vtu") as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
    return path


def snapshot_fields(signal: Signal, n_grains: int, dim: int) -> list[dict[str, np.ndarray]]:
    """Per snapshot: ``displacement`` (N, 3) and, with rotations, ``rotation`` (N, 3),
    scattered from the dof vector (rattlers and missing dofs stay 0)."""
    if signal.snapshot_time is None or signal.snapshot_displacement is None:
        raise InputError("the signal file has no snapshots (run propagate with --snapshots)")
    grain = np.asarray(signal.dof_grain, dtype=np.int64)
    axis = np.asarray(signal.dof_axis, dtype=np.int64)
    if len(grain) and (grain.max() >= n_grains or grain.min() < 0):
        raise InputError(f"the snapshots name grains beyond the {n_grains} of the positions given")
    rot = axis >= dim
    out = []
    for u in np.atleast_2d(signal.snapshot_displacement):
        disp = np.zeros((n_grains, 3))
        disp[grain[~rot], axis[~rot]] = u[~rot]
        fields = {"displacement": disp}
        if rot.any():
            rotation = np.zeros((n_grains, 3))
            # 2D: the one rotation is about z; 3D: axes dim..dim+2 are x, y, z
            ax = axis[rot] - dim
            rotation[grain[rot], ax + (2 if dim == 2 else 0)] = u[rot]
            fields["rotation"] = rotation
        out.append(fields)
    return out


def write_snapshot_series(path, signal: Signal, position: np.ndarray, radius: np.ndarray | None = None) -> list[Path]:
    """Write ``path`` (.pvd) and one .vtu per snapshot beside it (``<stem>_<k>.vtu``).

    ``position`` (N, dim): the equilibrium positions the displacements are measured
    from. Returns the files written (the .vtu files first, the .pvd last, so a
    collection never names a missing file).
    """
    meshio = _meshio()
    path = Path(path)
    if path.suffix != ".pvd":
        raise InputError(f"{path}: a snapshot series is written as a .pvd file")
    position = np.asarray(position, dtype=float)
    n, dim = position.shape
    fields = snapshot_fields(signal, n, dim)
    names = [f"{path.stem}_{k:04d}.vtu" for k in range(len(fields))]
    for name in names:  # every name before the first file: a bad one leaves nothing behind
        check_writable(path.parent / name)
    cells = [("vertex", np.arange(n, dtype=np.int64)[:, None])]
    written, datasets = [], []
    for k, (t, f) in enumerate(zip(signal.snapshot_time, fields)):
        name = names[k]
        point_data = dict(f)
        if radius is not None:
            point_data["radius"] = np.asarray(radius, dtype=float)
        mesh = meshio.Mesh(_points3(position), cells, point_data=point_data)
        with atomic_file(path.parent / name, suffix=".vtu") as tmp:
            meshio.write(tmp, mesh, file_format="vtu")
        written.append(path.parent / name)
        datasets.append((float(t), name))
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for t, name in datasets:
        ET.SubElement(coll, "DataSet", timestep=repr(t), group="", part="0", file=name)
    ET.indent(root)
    atomic_text(path, '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n")
    written.append(path)
    return written


def read_pvd(path) -> list[tuple[float, Path]]:
    """(time, file) of every dataset of a .pvd collection, in order."""
    root = ET.parse(path).getroot()
    base = Path(path).parent
    return [(float(ds.get("timestep")), base / ds.get("file")) for ds in root.iter("DataSet")]
