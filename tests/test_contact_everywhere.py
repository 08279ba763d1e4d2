"""A contact law wherever a packing is made: ``lattice``, ``chain``, ``prepare-packing``, the API,
the workflow config (per scene, checked at the dry run) and the files' provenance; the options'
help lists what the registry holds (granwave.contact_models), and so do the docs' tables
(tests/test_contact_registry.py checks those are current).
"""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from granwave import api
from granwave import contact as C
from granwave import contact_models as CM
from granwave.cli import main
from granwave.contact_models import options as CO
from granwave.errors import InputError
from granwave.io import files
from granwave.params import ChainParams, LatticeParams

ROOT = Path(__file__).resolve().parents[1]


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_lattice_takes_the_normal_and_tangential_laws():
    """The lattice's contacts carry f = p a / sqrt(3) with the law's overlap and k_n; k_t is the
    tangential law's; the file records both (not the defaults: Hertz lattices as before)."""
    p = 1e-6
    lat = api.lattice(rows=4, width=3, pressure=p, contact_law="cone", cone_slope=0.1, tangential="linear_history",
                      linear_history_stiffness=0.02, friction=0.3)
    c, wall = lat.contacts, lat.contacts.j < 0
    law = CM.model_of("normal", CO.values_of(dict(contact_law="cone", cone_slope=0.1)))
    e12 = np.where(wall, C.effective_young(True), C.effective_young(False))
    r12 = np.where(wall, 0.5, 0.25)
    np.testing.assert_allclose(c.force_normal[~wall], p * lat.attrs["spacing"] / math.sqrt(3), rtol=1e-13)
    np.testing.assert_allclose(c.force_normal, [CM.law_force(law, n, math.sqrt(r), e)
                                                for n, r, e in zip(c.overlap, r12, e12)], rtol=1e-13)
    np.testing.assert_allclose(c.stiffness_normal, [CM.law_stiffness(law, n, math.sqrt(r), e)
                                                    for n, r, e in zip(c.overlap, r12, e12)], rtol=1e-14)
    np.testing.assert_array_equal(c.stiffness_tangential, np.where(wall, 0.04, 0.02))
    assert {k: lat.attrs[k] for k in ("contact_law", "cone_slope", "tangential", "linear_history_stiffness")} == \
        dict(contact_law="cone", cone_slope=0.1, tangential="linear_history", linear_history_stiffness=0.02)
    hertz = api.lattice(rows=4, width=3, pressure=p)
    assert not set(CO.options()) & set(hertz.attrs)
    with pytest.raises(InputError, match="cone_slope must be > 0"):
        LatticeParams(rows=4, width=3, pressure=p, contact_law="cone", cone_slope=0.0)
    with pytest.raises(InputError, match="contact_law must be one of"):
        LatticeParams(rows=4, width=3, pressure=p, contact_law="hooke")


def test_chain_takes_a_normal_law_per_contact(tmp_path):
    """--contact-law: every contact (walls included) its own k_n and overlap of that law at force p;
    --hertz is its Hertz case, with the same arrays and attributes; such a file reads back (its
    ``stiffness`` is none: there is no one K; it was the string 'hertz', which no reader took)."""
    p = 1e-5
    ch = api.chain(balls=5, pressure=p, polydispersity=0.2, seed=3, contact_law="cone")
    c = ch.contacts
    values = CO.values_of(dict(contact_law="cone"))
    law = CM.model_of("normal", values)
    wall = c.j < 0
    r = ch.radius
    r12 = np.where(wall, r[c.i], r[c.i] * r[np.maximum(c.j, 0)] / (r[c.i] + r[np.maximum(c.j, 0)]))
    e12 = np.where(wall, 1.0, 0.5)
    np.testing.assert_allclose([CM.law_force(law, n, math.sqrt(a), e) for n, a, e in zip(c.overlap, r12, e12)],
                               p, rtol=1e-13)
    np.testing.assert_allclose(c.stiffness_normal, [CM.law_stiffness(law, n, math.sqrt(a), e)
                                                    for n, a, e in zip(c.overlap, r12, e12)], rtol=1e-14)
    assert (ch.attrs["stiffness_model"], ch.attrs["stiffness"], ch.attrs["contact_law"]) == ("law", None, "cone")
    old, new = api.chain(balls=5, pressure=p, hertz=True), api.chain(balls=5, pressure=p, contact_law="hertz")
    for field in ("position", "radius", "mass", "box"):
        np.testing.assert_array_equal(getattr(old, field), getattr(new, field))
    np.testing.assert_array_equal(old.contacts.stiffness_normal, new.contacts.stiffness_normal)
    assert {k: v for k, v in old.attrs.items() if k != "chain_params"} == \
        {k: v for k, v in new.attrs.items() if k != "chain_params"}
    assert "contact_law" not in old.attrs and old.attrs["stiffness_model"] == "hertz"
    for k, pk in enumerate((old, ch)):
        path = tmp_path / f"c{k}.h5"
        files.write_packing(path, pk)
        np.testing.assert_array_equal(files.read_packing(path).contacts.stiffness_normal, pk.contacts.stiffness_normal)
    with pytest.raises(InputError, match="either --stiffness K or --contact-law"):
        ChainParams(balls=3, pressure=p, stiffness=0.1, contact_law="cone")
    with pytest.raises(InputError, match="either --hertz or --contact-law cone"):
        ChainParams(balls=3, pressure=p, hertz=True, contact_law="cone")


def test_cli_options_and_their_help_come_from_the_registry(tmp_path):
    """lattice, chain and prepare-packing list every registered name of their kinds and every
    parameter of those kinds' sub-models among their options (generated: a new sub-model appears
    without an edit here); the options make the files."""
    kinds = {"lattice": ("normal", "tangential"), "chain": ("normal",), "prepare-packing": tuple(CO.KINDS)}
    for command, own in kinds.items():
        text = invoke(command, "--help").output
        for kind in own:
            option = "--" + CO.KINDS[kind]["option"].replace("_", "-")
            assert option in text, (command, option)
            for name in CO.names(kind):
                assert name in text, (command, name)
            for p, spec in CO.PARAMETERS.items():
                if spec["kind"] == kind:
                    assert "--" + p.replace("_", "-") in text, (command, p)
    out = tmp_path / "chain.h5"
    r = invoke("chain", "--balls", 6, "--pressure", 1e-6, "--contact-law", "cone_hertz", "--crossover-overlap",
               1e-4, "-o", out, "--quiet")
    assert r.exit_code == 0, r.output
    a = files.read_packing(out).attrs
    assert (a["contact_law"], a["crossover_overlap"], a["stiffness_model"]) == ("cone_hertz", 1e-4, "law")
    r = invoke("chain", "--balls", 6, "--pressure", 1e-6, "--contact-law", "cone", "--stiffness", 0.1,
               "-o", tmp_path / "bad.h5")
    assert r.exit_code == 2 and "not both" in r.output and not (tmp_path / "bad.h5").exists()


def test_provenance_the_law_travels_with_the_sample():
    """The packing records the law, linearize copies it, and the workflow's summary of a sample
    carries it (the packing's attributes: the normal law always)."""
    from granwave.analysis.sweep import merge_summary

    lat = api.lattice(rows=4, width=3, pressure=1e-6, contact_law="cone")
    s = api.linearize(lat)
    assert s.attrs["contact_law"] == "cone" and s.attrs["cone_slope"] == CO.PARAMETERS["cone_slope"]["default"]
    contact = CO.attrs_of(CO.values_of_attrs(lat.attrs))
    summary = merge_summary(attrs=dict(pressure=1e-6, seed=0, kind="lattice", height=3.0), scene="x", **contact)
    assert summary["contact_law"] == "cone" and summary["cone_slope"] == contact["cone_slope"]
    assert CO.attrs_of(CO.values_of_attrs(api.lattice(rows=4, width=3, pressure=1e-6).attrs)) == \
        dict(contact_law=CO.KINDS["normal"]["default"])


def test_workflow_config_contact_is_checked_per_scene():
    """granwave.workflow_config.contact_error: one line naming the key for an unknown key (a lattice
    has no dashpot), a sub-model not registered, a parameter out of range or of the wrong type, a
    rolling model without friction; a good mapping passes; and the samples' options carry it."""
    from granwave import workflow_config as ws

    def config(kind, contact, **spec):
        return {kind: {"s": dict(spec, contact=contact)}}

    assert ws.contact_error(config("lattices", {"contact_law": "cone", "cone_slope": 0.1})) is None
    assert ws.contact_error(config("disordered", {"damping_law": "constant_viscous", "viscous_damping": 0.01},
                                   friction=0.5)) is None
    cases = [
        (config("lattices", {"damping_law": "constant_viscous"}), "unknown key lattices.s.contact.damping_law"),
        (config("chains", {"tangential": "linear_history"}), "unknown key chains.s.contact.tangential"),
        (config("disordered", {"contact_law": "hooke"}), "disordered.s.contact.contact_law: unknown contact law 'hooke'"),
        (config("disordered", {"contact_law": "cone", "cone_slope": -1.0}),
         "disordered.s.contact.cone_slope: cone_slope must be > 0"),
        (config("continuum", {"cone_slope": "steep"}), "continuum.s.contact.cone_slope: must be a number"),
        (config("disordered", {"rolling": "sds"}, friction=0.0), "disordered.s.contact.rolling: rolling 'sds' needs "
                                                                 "friction > 0"),
    ]
    for cfg, message in cases:
        text = ws.contact_error(cfg)
        assert text is not None and text.startswith("config: ") and message in text, (text, message)
        assert "\n" not in text
    keys = ws.sample_keys({"lattices": {"s": {"rows": [4], "pressures": [1e-6]}}}, "lattices", "s",
                          dict(size="r4", pressure="1e-06"))
    assert keys["cone_slope"] == "lattices.s.contact.cone_slope"


def test_workflow_dry_run_takes_the_laws_config_and_refuses_a_bad_contact(tmp_path):
    """config/laws.yaml parses (its lattice and disordered scenes of each law in the job graph); a
    config whose scene names a parameter out of range stops the dry run with one line naming the key."""
    import yaml

    def dry(config):
        return subprocess.run([sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"), "-n",
                               "--cores", "1", "--configfile", str(config)], cwd=tmp_path, capture_output=True,
                              text=True, timeout=600)
    run = dry(ROOT / "config" / "laws.yaml")
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    for scene in ("laws_hertz", "laws_cone", "laws_cone_hertz"):
        assert f"batch_{scene}_0" in run.stdout
    cfg = yaml.safe_load((ROOT / "config" / "laws.yaml").read_text())
    cfg["disordered"]["laws_cone"]["contact"]["cone_slope"] = 0.0
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    run = dry(bad)
    assert run.returncode != 0 and "Traceback" not in run.stderr
    assert "config: disordered.laws_cone.contact.cone_slope: cone_slope must be > 0" in run.stderr
