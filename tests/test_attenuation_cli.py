"""`granwave analyze attenuation` with the packings' moduli files: the lateral cutoff
2π c_t/W and the c_ℓ that c0 is compared with come from their mean speeds."""

import json
import math

from click.testing import CliRunner
import numpy as np

from granwave.cli import main
from granwave.io.files import write_signal
from test_attenuation_truth import ensemble


def _files(tmp_path, c_t):
    signals = []
    for k, sig in enumerate(ensemble(0, n=3, heights=(10.0, 20.0, 40.0))):
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
    out = json.loads(res.output)
    assert math.isclose(out["omega_cutoff"], 2 * math.pi * 0.55 / 20, rel_tol=1e-12)
    assert math.isclose(out["c_l"], np.mean([1.0, 1.01, 1.02]), rel_tol=1e-12)
    given = json.loads(_run(*signals, *flags, "--lateral-period", "20", "--omega-cutoff", "0.3",
                            "--c-l", "2", "--bootstrap", "0", "--json").output)
    assert given["omega_cutoff"] == 0.3 and given["c_l"] == 2.0  # the options win


def test_lateral_period_without_moduli_is_refused_in_one_line(tmp_path):
    signals, _ = _files(tmp_path, [])
    res = _run(*signals, "--lateral-period", "20", "--bootstrap", "0", "--json")
    assert res.exit_code == 2
    assert "--lateral-period needs --moduli" in res.output
