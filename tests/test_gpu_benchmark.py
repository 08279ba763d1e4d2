"""benchmarks/gpu.py --all's JSON: its shape at toy sizes in numba's CUDA simulator (``--tiny``,
which claims no speed), its one-line exit without a GPU, and benchmarks/results/record_gpu.py
reading it (a simulator run is not recorded)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GOALS = {"dem_rate", "td_speedup", "td_roofline", "columns_s", "batch_per_packing", "ensemble_statics",
         "all_wall_s"}


def _run(args, env=None, tmp=None):
    return subprocess.run([sys.executable, str(ROOT / "benchmarks" / "gpu.py"), *args], capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}, cwd=tmp,
                          timeout=600)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("gpu_all") / "gpu_all.json"
    r = _run(["--all", "--tiny", "--parts", "bandwidth,batch", "--out", str(out)])
    assert r.returncode == 0, r.stderr[-3000:]
    return out, json.loads(out.read_text())


def test_gpu_all_tiny_json_has_every_goal_and_claims_no_speed(tiny):
    _, res = tiny
    assert res["simulator"] is True and "not" in res["note"]
    assert set(res["goal_table"]) == GOALS
    for name, row in res["goal_table"].items():
        assert {"what", "measured", "goal", "pass", "from"} <= set(row), name
        assert row["pass"] is None and row["measurement"] is False, name  # the simulator measures nothing
    b = res["batch"]  # the batch of packings against CPU cores, at toy sizes: the same code path
    assert b["packings"] == 2 and b["cpu_cores"] == 2
    assert b["gpu"]["steps"] == [3, 3] and b["gpu"]["rounds"] >= 1  # each packing stepped in the batch
    assert b["cpu"]["done"] == 2  # the same work on the CPU processes
    assert res["goal_table"]["all_wall_s"]["measured"] == res["wall_s"] > 0


def test_record_gpu_reads_the_json_and_refuses_a_simulator_run(tiny):
    out, _ = tiny
    script = str(ROOT / "benchmarks" / "results" / "record_gpu.py")
    before = (ROOT / "benchmarks" / "results" / "gpu.jsonl").read_bytes()
    r = subprocess.run([sys.executable, script, str(out), "--revision", "x", "--print"], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    head = json.loads(r.stdout)
    assert {f"goal {g}" for g in GOALS} <= set(head)
    assert any("packings of 10 grains in one batch" in k for k in head)
    r = subprocess.run([sys.executable, script, str(out), "--revision", "x"], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 2 and "simulator" in r.stderr
    assert (ROOT / "benchmarks" / "results" / "gpu.jsonl").read_bytes() == before


def test_gpu_all_without_a_gpu_is_one_line_exit_2_no_file(tmp_path):
    if os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0"):
        pytest.skip("the CUDA simulator is on: it counts as a GPU")
    from granwave.errors import InputError
    from granwave.gpu import require_gpu

    try:
        require_gpu()
        pytest.skip("a GPU is usable here")
    except InputError:
        pass
    r = _run(["--all", "--out", str(tmp_path / "gpu_all.json")], env={"NUMBA_ENABLE_CUDASIM": "0"})
    assert r.returncode == 2
    lines = [x for x in (r.stdout + r.stderr).splitlines() if x.strip()]
    assert len(lines) == 1 and "no usable CUDA GPU" in lines[0], lines
    assert list(tmp_path.iterdir()) == []
