"""The compaction rule of the piston protocol (dem.protocol.damping_scale): the height-scaled
background damping converges, records itself and is reproducible; 'fixed' is the protocol before."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from click.testing import CliRunner

from granwave.cli import main as cli_main
from granwave.dem.forces import static_residual
from granwave.dem.protocol import COMPACTION_RULES, damping_scale, expected_height, prepare_packing
from granwave.geometry import lateral_size, wall_area
from granwave.io import files
from granwave.params import PrepareParams

#: 80 grains, seed 3, aspect 2 (expected height 12.5 d) as prepared by the protocol before the
#: compaction rule existed (background damping b / t_i at every height): sha256 of the arrays
#: (see digest) and the step count. Both rules must reproduce it below reference_height.
BEFORE = dict(grains=80, seed=3, aspect=2.0)
BEFORE_DIGEST = "88df15a2b4cd0435a5d065a527249a0d6c141d7a9307212b0f592dc7d207b075"
BEFORE_STEPS = 19020
#: a reference height below the column's, so that the height-scaled rule acts
SCALED = dict(BEFORE, reference_height=5.0, compaction="height-scaled")


def digest(packing) -> str:
    h = hashlib.sha256()
    c = packing.contacts
    for a in (packing.position, packing.radius, packing.box, c.i, c.j, c.normal, c.overlap, c.force_normal,
              c.force_tangential):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def scaled():
    return prepare_packing(PrepareParams(**SCALED))


def test_damping_scale_rule():
    assert PrepareParams().compaction == "fixed"  # the default: the protocol before
    assert damping_scale(PrepareParams(), 400.0) == 1.0
    scaled = PrepareParams(compaction="height-scaled")
    assert damping_scale(scaled, 25.0) == 1.0  # up to reference_height: b unscaled
    assert damping_scale(scaled, 100.0) == 0.25
    assert damping_scale(PrepareParams(compaction="height-scaled", reference_height=10.0), 40.0) == 0.25


def test_expected_height_inverts_lateral_size():
    rng = np.random.default_rng(0)
    r = 0.5 * rng.uniform(0.8, 1.2, 500)
    w = lateral_size(r, 2, 3.0)
    assert expected_height(r, np.array([w])) == pytest.approx(3.0 * w, rel=1e-12)
    w3 = lateral_size(r, 3, 2.0)
    assert expected_height(r, np.array([w3, w3])) == pytest.approx(2.0 * w3, rel=1e-12)


def test_height_scaled_converges_and_records_its_protocol(scaled):
    a = scaled.attrs
    h_e = expected_height(scaled.radius, scaled.box[:-1])
    assert h_e == pytest.approx(2.0 * scaled.box[0], rel=1e-12)  # aspect 2
    assert a["compaction"] == "height-scaled" and a["compaction_rule"] == COMPACTION_RULES["height-scaled"]
    assert a["reference_height"] == 5.0 and a["expected_height"] == h_e
    assert a["background_damping_scale"] == 5.0 / h_e
    assert a["background_damping_rate"] == pytest.approx(0.3 * (5.0 / h_e) / a["inertial_time"], rel=1e-14)
    # in equilibrium: the static residual from the stored contacts alone is below tol
    res = static_residual(scaled, a["piston_mass"], 1e-4 * wall_area(scaled.box[:-1]))
    assert max(res) < 1e-10 and a["max_acceleration"] == max(res)
    assert a["converged"] and a["steps"] != BEFORE_STEPS  # another trajectory than the fixed rule
    assert digest(scaled) != BEFORE_DIGEST


def test_height_scaled_same_seed_same_bytes(scaled, tmp_path):
    again = prepare_packing(PrepareParams(**SCALED))
    files.write_packing(tmp_path / "a.h5", scaled)
    files.write_packing(tmp_path / "b.h5", again)
    assert (tmp_path / "a.h5").read_bytes() == (tmp_path / "b.h5").read_bytes()


@pytest.mark.parametrize("compaction", ["fixed", "height-scaled"])
def test_before_reproduced(compaction):
    """'fixed' at any height, and 'height-scaled' below reference_height, are the protocol
    before: the same arrays to the byte and the same steps."""
    pk = prepare_packing(PrepareParams(**BEFORE, compaction=compaction))
    assert pk.attrs["background_damping_scale"] == 1.0
    assert pk.attrs["background_damping_rate"] == 0.3 / pk.attrs["inertial_time"]
    assert pk.attrs["steps"] == BEFORE_STEPS
    assert digest(pk) == BEFORE_DIGEST


def test_fixed_ignores_height():
    pk = prepare_packing(PrepareParams(**{**SCALED, "compaction": "fixed"}))
    assert pk.attrs["compaction"] == "fixed" and pk.attrs["background_damping_scale"] == 1.0
    assert digest(pk) == BEFORE_DIGEST


def test_cli_options(tmp_path):
    out = CliRunner().invoke(cli_main, ["prepare-packing", "--help"]).output
    assert "--compaction" in out and "--reference-height" in out
    target = tmp_path / "x.h5"
    bad = CliRunner().invoke(cli_main, ["prepare-packing", "--compaction", "fire", "-o", str(target)])
    assert bad.exit_code == 2 and not target.exists()
