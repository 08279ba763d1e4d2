"""The contact sub-models (granwave.contact_models: every one but code 0 of its kind) on the GPU engine against the CPU engine, in numba's CUDA simulator: a two-grain collision
with friction, damping and spins, 30 steps; prints one JSON line {selection: {max_abs, same_bytes,
overlap, tangential_force}} (tests/test_gpu_submodels.py runs it with NUMBA_ENABLE_CUDASIM=1)."""

import json

import numpy as np

from granwave.contact_models import options as CO
from granwave.dem.integrator import Engine
from granwave.gpu.dem import GpuEngine

STATE = ("position", "velocity", "acceleration", "angular_velocity", "angular_acceleration")


def run(cls, contact, steps=30):
    e = cls(np.array([[5.0, 3.0], [5.9, 3.3]]), np.array([0.5, 0.45]), [12.0], 8.0, friction=0.5, damping=0.3,
            dt=2e-3, velocity=[[0.3, 0.05], [-0.2, 0.0]], angular_velocity=[[0.4], [-1.0]], **contact)
    e.run(steps)
    return e


def selections():
    """Each registered sub-model but its kind's code 0 (the defaults, which tests/test_gpu_sim.py
    covers) that runs on the GPU, the others at their defaults, its parameters at theirs (the
    crossover law's n* lowered into the collision's overlaps, to pass both branches)."""
    out = {}
    for name, s in CO.SUBMODELS.items():
        if s["code"] == 0 or "gpu" not in s["devices"]:
            continue
        contact = {CO.KINDS[s["kind"]]["option"]: name}
        if "crossover_overlap" in s["parameters"]:
            contact["crossover_overlap"] = 1e-2
        out[name] = contact
    return out


if __name__ == "__main__":
    result = {}
    for name, contact in selections().items():
        a, b = run(Engine, contact), run(GpuEngine, contact)
        m = a.n_pairs
        d = max(float(np.max(np.abs(getattr(a, k) - getattr(b, k)))) for k in STATE)
        d = max(d, float(np.max(np.abs(a.pair_ft[:m] - b.pair_ft[:m]), initial=0.0)))
        result[name] = dict(max_abs=d, same_bytes=all(getattr(a, k).tobytes() == getattr(b, k).tobytes() for k in STATE),
                            overlap=float(a.pair_ov[:m].max(initial=0.0)),
                            tangential_force=float(np.abs(a.pair_ft[:m, :2]).max(initial=0.0)))
    print(json.dumps(result))
