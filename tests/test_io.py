"""HDF5 schema: round trips, refusal of foreign files and versions, atomic writes."""

import platform

import h5py
import numpy as np
import pytest

from granwave.errors import InputError
from granwave.io import files, schema
from granwave.model import Contacts, Packing


def tiny_packing():
    contacts = Contacts(
        i=np.array([0, 0]), j=np.array([1, -1]),
        normal=np.array([[1.0, 0.0], [0.0, -1.0]]), overlap=np.array([1e-3, 2e-3]),
        force_normal=np.array([1e-4, 2e-4]), force_tangential=np.zeros((2, 2)),
        stiffness_normal=np.array([0.1, 0.2]), stiffness_tangential=np.array([0.1, 0.2]),
    )
    return Packing(position=np.array([[0.5, 0.5], [1.5, 0.5]]), radius=np.array([0.5, 0.5]),
                   mass=np.full(2, np.pi / 6), inertia=np.full(2, np.pi / 60), box=np.array([2.0, 1.0]),
                   contacts=contacts,
                   attrs=dict(pressure=1e-4, friction=0.5, poisson=0.0, seed=3, converged=True,
                              max_acceleration=1e-12, kind="test"))


def test_packing_round_trip(tmp_path):
    p = tiny_packing()
    files.write_packing(tmp_path / "p.h5", p)
    q = files.read_packing(tmp_path / "p.h5")
    np.testing.assert_array_equal(q.position, p.position)
    np.testing.assert_array_equal(q.contacts.j, p.contacts.j)
    assert q.attrs["seed"] == 3 and q.attrs["kind"] == "test" and q.dim == 2
    with h5py.File(tmp_path / "p.h5") as f:
        assert f.attrs["schema"] == schema.PACKING
        assert f["contacts/overlap"].attrs["units"] == "d_bar"
        assert "granwave_version" in f.attrs
        # how it was made: the libraries' versions and the machine (whose SIMD loops once
        # changed the bits of a packing, docs/dem.md "The same bits on every machine")
        assert f"numpy {np.__version__}" in f.attrs["software"]
        assert f"h5py {h5py.__version__}" in f.attrs["software"]
        assert f.attrs["machine"].startswith(platform.machine()) and "numpy SIMD" in f.attrs["machine"]


def test_a_packing_its_reader_would_refuse_is_not_written(tmp_path):
    """An overlap above half the smaller radius (a pressure too high for so few grains) fails the
    reader's checks: the writer refuses it in one line and leaves no file."""
    p = tiny_packing()
    p.contacts.overlap[0] = 0.3
    with pytest.raises(InputError, match=r"overlaps by 0\.3, more than 0\.5 of the radius .*not written"):
        files.write_packing(tmp_path / "p.h5", p)
    assert list(tmp_path.iterdir()) == []


def test_refuses_foreign_schema_and_major_version(tmp_path):
    files.write_packing(tmp_path / "p.h5", tiny_packing())
    with pytest.raises(InputError, match="expected a granwave.signal file"):
        files.read_signal(tmp_path / "p.h5")
    with h5py.File(tmp_path / "p.h5", "a") as f:
        f.attrs["schema_version"] = "2.0"
    with pytest.raises(InputError, match="schema version"):
        files.read_packing(tmp_path / "p.h5")
    (tmp_path / "x.h5").write_text("not hdf5")
    with pytest.raises(InputError, match="not an HDF5 file"):
        files.read_packing(tmp_path / "x.h5")


def test_nan_in_file_is_refused(tmp_path):
    p = tiny_packing()
    p.position[0, 0] = np.nan
    with pytest.raises(InputError, match="NaN"):
        files.write_packing(tmp_path / "p.h5", p)
    files.write_packing(tmp_path / "p.h5", p, check=False)
    with pytest.raises(InputError, match="NaN"):
        files.read_packing(tmp_path / "p.h5")


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    with pytest.raises(RuntimeError):
        with files.atomic_h5(tmp_path / "out.h5", schema.SIGNAL, {"ic": "A"}):
            raise RuntimeError("killed halfway")
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_is_refused_early(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        files.check_writable(tmp_path / "missing" / "out.h5")


def test_attrs_copied_from_another_file_cannot_relabel_it(tmp_path):
    from granwave.model import Signal
    sig = Signal(time=np.arange(3.0), force=np.zeros(3),
                 attrs={"schema": schema.LINEAR, "schema_version": "9.9", "ic": "A",
                        "method": "modal", "height": 1.0})
    files.write_signal(tmp_path / "s.h5", sig)
    back = files.read_signal(tmp_path / "s.h5")
    assert back.attrs["schema"] == schema.SIGNAL
    assert back.attrs["schema_version"] == schema.VERSIONS[schema.SIGNAL]
