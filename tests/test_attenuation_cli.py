"""`granwave analyze attenuation` with the packings' moduli files: the lateral cutoff
2π c_t/W from their mean c_t; the c_ℓ reference of c0 and λ* from their mean, or, with one file
per signal, from the packings of the heights that enter the fits."""

import json
import math
import sys
from pathlib import Path

from click.testing import CliRunner
import numpy as np

from granwave.cli import main
from granwave.io.files import write_signal

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.truth_cases._ensembles import Design, ensemble  # noqa: E402

SMALL = Design(heights=(16.0, 32.0, 64.0), packings=(3, 3, 3))


def _files(tmp_path, c_t):
    signals = []
    for k, sig in enumerate(ensemble(SMALL, 0)[0]):
        path = tmp_path / f"s{k}.h5"
        write_signal(path, sig)
        signals.append(path)
    moduli = []
    for k, ct in enumerate(c_t):
        path = tmp_path / f"m{k}.json"
        path.write_text(json.dumps({"c_l": 0.9, "c_t": 0.4, "c_l_slab": 1.0 + 0.01 * k, "c_t_slab": ct}))
        moduli.append(path)
    return signals, moduli


def _run(*args):
    return CliRunner().invoke(main, ["analyze", "attenuation", *[str(a) for a in args]])


def test_cutoff_and_c_l_from_the_moduli_files(tmp_path):
    signals, moduli = _files(tmp_path, [0.5, 0.6, None])  # a failed solve (null) is left out
    flags = [x for m in moduli for x in ("--moduli", m)]
    res = _run(*signals, *flags, "--lateral-period", "20", "--bootstrap", "0", "--json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert math.isclose(out["omega_cutoff"], 2 * math.pi * 0.55 / 20, rel_tol=1e-12)
    assert math.isclose(out["c_l"], np.mean([1.0, 1.01, 1.02]), rel_tol=1e-12)
    given = json.loads(_run(*signals, *flags, "--lateral-period", "20", "--omega-cutoff", "0.3",
                            "--c-l", "2", "--bootstrap", "0", "--json").stdout)
    assert given["omega_cutoff"] == 0.3 and given["c_l"] == 2.0  # the options win


def test_one_moduli_file_per_signal_gives_the_contributing_heights_reference(tmp_path):
    signals, moduli = _files(tmp_path, [0.5] * 9)  # c_l_slab 1.00, 1.01, ... 1.08 in signal order
    flags = [x for m in moduli for x in ("--moduli", m)]
    res = _run(*signals, *flags, "--lateral-period", "20", "--bootstrap", "0", "--json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    lam = out["continuum_length"]
    assert out["c_l_reference"] == "the packings of the contributing heights" and lam["reference"] == "c_l"
    heights = [round(h) for h in out["heights"]]
    want = [1.0 + 0.01 * k for k, h in enumerate(np.repeat(heights, 3))
            if round(h) in {round(x) for x in lam["contributing_heights"]}]
    assert math.isclose(lam["c_ref"], np.mean(want), rel_tol=1e-12)
    assert math.isclose(out["c0_over_c_l"], out["c0"] / np.mean(want), rel_tol=1e-12)
    text = _run(*signals, *flags, "--lateral-period", "20", "--bootstrap", "0").output
    assert "c_ref = c_l" in text and "set by" in text


def test_lateral_period_without_moduli_is_refused_in_one_line(tmp_path):
    signals, _ = _files(tmp_path, [])
    res = _run(*signals, "--lateral-period", "20", "--bootstrap", "0", "--json")
    assert res.exit_code == 2
    assert "--lateral-period needs --moduli" in res.output
