"""Every kind of granwave file opens in xarray with named dimensions and pint units.

Files come from the real stages (lattice -> linearize -> eigensolve -> propagate,
ensemble and sweep through the writers' shared layer); each is opened with
``xarray.open_datatree(path, engine="h5netcdf")`` and checked for: no anonymous
``phony_dim`` dimension, the dimension names of the schema, coordinates
(signal/force indexed by signal/time, contacts carrying their grains i, j), units
that pint parses with granwave's definitions, and the readers still reading.
"""

import numpy as np
import pytest

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")
pint = pytest.importorskip("pint")

from granwave.analysis.ensemble import Ensemble, read_ensemble, write_ensemble  # noqa: E402
from granwave.io import files  # noqa: E402
from granwave.io import schema as S  # noqa: E402
from granwave.linear.assemble import linearize  # noqa: E402
from granwave.linear.eigen import eigensolve  # noqa: E402
from granwave.linear.propagate import modal_propagate  # noqa: E402
from granwave.systems import triangular_lattice  # noqa: E402
from granwave.units import registry  # noqa: E402


@pytest.fixture(scope="module")
def stage_files(tmp_path_factory):
    """One file of each kind, from a small frictional lattice (rotations present)."""
    d = tmp_path_factory.mktemp("xr")
    packing = triangular_lattice(rows=4, width=6, pressure=1e-4, friction=0.5)
    system = linearize(packing)
    modes = eigensolve(system, vectors=True)
    signal = modal_propagate(modes, ic="A", t_max=20.0, samples=101, snapshots=[5.0, 10.0],
                             dof_grain=system.dof_grain, dof_axis=system.dof_axis)
    paths = {k: d / f"{k}.h5" for k in ("packing", "linear", "modes", "signal", "ensemble", "sweep")}
    files.write_packing(paths["packing"], packing)
    files.write_linear(paths["linear"], system)
    files.write_modes(paths["modes"], modes)
    files.write_signal(paths["signal"], signal)
    write_ensemble(paths["ensemble"], Ensemble(time=signal.time, mean=signal.force,
                                               rms=0.1 * np.abs(signal.force), attrs={"n_signals": 3}))
    with files.atomic_h5(paths["sweep"], S.SWEEP, {}) as f:
        files.put(f, S.SWEEP, "sweep/pressure", np.array([1e-5, 1e-4]))
        files.put(f, S.SWEEP, "sweep/quantity", np.array([b"statics.z", b"moduli.c22"], dtype="S"))
        files.put(f, S.SWEEP, "sweep/mean", np.ones((2, 2)))
        files.put(f, S.SWEEP, "sweep/c_l", np.array([0.1, 0.2]))
    return dict(paths=paths, packing=packing, system=system, modes=modes, signal=signal)


def _all_dims(tree) -> set[str]:
    return {dim for node in tree.subtree for dim in node.dataset.dims}


def _variables(tree):
    for node in tree.subtree:
        for name, var in node.dataset.variables.items():
            yield f"{node.path.strip('/')}/{name}".strip("/"), var


@pytest.mark.parametrize("kind", ["packing", "linear", "modes", "signal", "ensemble", "sweep"])
def test_every_file_opens_with_named_dimensions_and_pint_units(stage_files, kind):
    path = stage_files["paths"][kind]
    tree = xr.open_datatree(path, engine="h5netcdf")
    dims = _all_dims(tree)
    assert dims and not any(d.startswith("phony_dim") for d in dims), dims
    schema = files.file_schema(path)
    ureg = registry()
    seen = 0
    for name, var in _variables(tree):
        if name not in S.DATASETS[schema]:
            continue  # dimension scales (axis labels)
        seen += 1
        assert var.dims == S.DIMS[schema][name], name
        for key in ("units", "units_rotation", "units_translation_rotation"):
            if key in var.attrs:
                ureg.parse_units(var.attrs[key])  # raises on anything pint cannot read
    assert seen >= 3


def test_packing_dimensions_and_contact_coordinates(stage_files):
    pk = stage_files["packing"]
    tree = xr.open_datatree(stage_files["paths"]["packing"], engine="h5netcdf")
    grains, contacts = tree["grains"].dataset, tree["contacts"].dataset
    assert grains["position"].dims == ("grain", "axis")
    assert grains.sizes["grain"] == pk.n_grains
    assert list(tree.dataset["axis"].values) == ["x", "y"]
    # contacts are linked to their grains: i and j are coordinates of every contact variable
    fn = contacts["force_normal"]
    assert {"i", "j"} <= set(fn.coords)
    np.testing.assert_array_equal(fn.coords["i"].values, pk.contacts.i)
    np.testing.assert_array_equal(fn.coords["j"].values, pk.contacts.j)
    np.testing.assert_array_equal(fn.values, pk.contacts.force_normal)
    # the readers still read the file
    back = files.read_packing(stage_files["paths"]["packing"])
    np.testing.assert_array_equal(back.position, pk.position)


def test_signal_force_indexed_by_time(stage_files):
    sig = stage_files["signal"]
    tree = xr.open_datatree(stage_files["paths"]["signal"], engine="h5netcdf")
    force = tree["signal"].dataset["force"]
    assert force.dims == ("time",)
    np.testing.assert_array_equal(force.coords["time"].values, sig.time)
    # label-based selection works on the time coordinate
    t = sig.time[37]
    assert float(force.sel(time=t)) == sig.force[37]
    snap = tree["snapshots"].dataset["displacement"]
    assert snap.dims == ("time", "dof")
    np.testing.assert_array_equal(snap.coords["time"].values, sig.snapshot_time)
    back = files.read_signal(stage_files["paths"]["signal"])
    np.testing.assert_array_equal(back.snapshot_displacement, sig.snapshot_displacement)


def test_linear_mass_units_tell_translations_from_rotations(stage_files):
    """The per-dof mass carries rho d^3 for translations and rho d^5 for rotations, and the
    rule (dof/axis < dim) recovers exactly the grain masses and moments of inertia."""
    system, pk = stage_files["system"], stage_files["packing"]
    tree = xr.open_datatree(stage_files["paths"]["linear"], engine="h5netcdf")
    mass = tree.dataset["mass"]
    ureg = registry()
    assert ureg.parse_units(mass.attrs["units_translation"]) == ureg.parse_units("rho * d_bar**3")
    assert ureg.parse_units(mass.attrs["units_rotation"]) == ureg.parse_units("rho * d_bar**5")
    axis = tree["dof"].dataset["axis"].values
    grain = tree["dof"].dataset["grain"].values
    dim = int(tree.attrs["dim"])
    rot = axis >= dim
    assert rot.any() and (~rot).any()
    np.testing.assert_allclose(mass.values[~rot], pk.mass[grain[~rot]], rtol=1e-15)
    np.testing.assert_allclose(mass.values[rot], pk.inertia[grain[rot]], rtol=1e-15)
    back = files.read_linear(stage_files["paths"]["linear"])
    assert (back.stiffness != system.stiffness).nnz == 0


def test_modal_units_multiply_to_a_force(stage_files):
    """a_n b_n is the amplitude of a signal term: its units must be a force, E* d^2."""
    tree = xr.open_datatree(stage_files["paths"]["modes"], engine="h5netcdf")
    ureg = registry()
    a = ureg.parse_units(tree.dataset["amplitude_A"].attrs["units"])
    b = ureg.parse_units(tree.dataset["coupling"].attrs["units"])
    assert (1 * a * b).to("E_star * d_bar**2").magnitude == pytest.approx(1.0)
    assert tree.dataset["vectors"].dims == ("dof", "mode")
    back = files.read_modes(stage_files["paths"]["modes"], vectors=True)
    np.testing.assert_array_equal(back.omega2, stage_files["modes"].omega2)


def test_units_convert_to_si_with_a_material():
    """With glass beads (d = 1 mm, rho = 2500 kg/m^3, E* = 70 GPa) the time unit is
    d sqrt(rho/E*) = 1e-3 * sqrt(2500/7e10) s = 0.18898 us (computed here by hand)."""
    ureg = registry(diameter="1 mm", density="2500 kg/m^3", modulus="70 GPa")
    t = (1.0 * ureg.parse_units(S.DATASETS[S.SIGNAL]["signal/time"][0])).to("s").magnitude
    assert t == pytest.approx(1e-3 * np.sqrt(2500 / 7e10), rel=1e-12)
    f = (1.0 * ureg.parse_units(S.DATASETS[S.SIGNAL]["signal/force"][0])).to("N").magnitude
    assert f == pytest.approx(7e10 * 1e-6, rel=1e-12)


def test_ensemble_reader_still_reads(stage_files):
    ens = read_ensemble(stage_files["paths"]["ensemble"])
    np.testing.assert_array_equal(ens.time, stage_files["signal"].time)
