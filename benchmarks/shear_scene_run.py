"""Run a config's shear scene without Snakemake, leanly: for each packing the shear scene
selects, only what the shear kicks need (the DEM packing, its linear system, its global
moduli for c_t and c_l), then the shear and compressional kicks with every pick
(granwave.workflow_support.run_shear_sample) and the scene's analysis
(granwave.analysis.shear_scene.shear_scene), at the workflow's own paths and options.

The workflow's batches also make each packing's normal signal, front, statics and local
moduli, which the shear scene does not use; on busy cores the local moduli of the
softest 3D packings (p = 1e-7: a dense minimum-norm solve per loading) cost minutes each.
Files the workflow (or an earlier run) already made are reused.

    PYTHONPATH=. python benchmarks/shear_scene_run.py config/shear.yaml shear3d [--seeds N]
    [--pressures P ...]   (a second process for some pressures; the full run then reuses its files)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import yaml


def _fmt_p(p: float) -> str:
    return f"{p:g}"


def _height_label(h: float) -> str:
    return f"h{float(h):g}"


def grain_count(spec: dict, height: float) -> int:
    """As workflow/rules/common.smk's grain_count."""
    w = spec["width"]
    if spec.get("dim", 2) == 2:
        return max(1, round(w * height))
    return max(1, round(w * w * height * 0.62 / (math.pi / 6)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("scene", help="a shear scene of the config")
    ap.add_argument("--seeds", type=int, default=None, help="at most this many seeds per point")
    ap.add_argument("--pressures", type=float, nargs="+", default=None,
                    help="only these pressures, no analysis (a second process sharing the work)")
    args = ap.parse_args()

    from granwave.analysis.shear_scene import shear_scene
    from granwave.io import files
    from granwave.io.files import atomic_text, jsonable
    from granwave.linear.assemble import linearize
    from granwave.linear.moduli import moduli
    from granwave.workflow_support import STATICS_LAYER, make_sample, run_shear_sample

    cfg = yaml.safe_load(Path(args.config).read_text())
    R = cfg.get("results", "results")
    sh = cfg["shear"][args.scene]
    src = sh["scene"]
    spec = {"dim": 2, "friction": 0.5, "poisson": 0.0, "polydispersity": 0.2, "width": 24,
            "tol": 1e-10, "max_steps": 5_000_000, **cfg["disordered"][src]}
    seeds = min(spec["seeds"], args.seeds or spec["seeds"], sh.get("seeds") or spec["seeds"])
    heights = sh.get("heights") or spec["heights"]
    pressures = args.pressures or sh.get("pressures") or spec["pressures"]
    lams = [float(w) for w in sh.get("wavelengths", [8, 4, 16])]
    picks = []
    for p in pressures:
        for h in heights:
            for seed in range(seeds):
                tail = f"{src}/p{_fmt_p(p)}/{_height_label(h)}/s{seed}"
                paths = {k: Path(R) / k / f"{tail}.{ext}" for k, ext in
                         (("packing", "h5"), ("linear", "h5"), ("moduli", "json"))}
                for path in paths.values():
                    path.parent.mkdir(parents=True, exist_ok=True)
                t0 = time.process_time()
                if not paths["packing"].exists():
                    make = dict(dim=spec["dim"], grains=grain_count(spec, h),
                                aspect=float(f"{h / spec['width']:.6g}"), pressure=float(p),
                                friction=float(spec["friction"]), poisson=float(spec["poisson"]),
                                polydispersity=float(spec["polydispersity"]), tol=float(spec["tol"]),
                                max_steps=int(spec["max_steps"]), seed=seed)
                    files.write_packing(paths["packing"], make_sample("disordered", make))
                pk = files.read_packing(paths["packing"])
                if not paths["linear"].exists():
                    pk.attrs["source_file"] = str(paths["packing"])
                    files.write_linear(paths["linear"], linearize(pk))
                if not paths["moduli"].exists():
                    m = moduli(pk, local=False, layer=STATICS_LAYER)
                    atomic_text(paths["moduli"], json.dumps(jsonable(m), indent=1) + "\n")
                stail = f"{args.scene}/p{_fmt_p(p)}/{_height_label(h)}/s{seed}"
                sample = {"scene": args.scene, "source_scene": src, "pressure": _fmt_p(p),
                          "size": _height_label(h), "seed": seed, "wavelengths": lams,
                          "pulse": sh.get("pulse", "ricker"), "method": sh.get("method", "auto"), "safety": sh.get("time_safety", 0.1),
                          "samples": sh.get("samples", 2000), "record": sh.get("record", 3.0),
                          "in": {"linear": str(paths["linear"]), "moduli": str(paths["moduli"])},
                          "out": {"shear_signal": str(Path(R) / "shear_signal" / f"{stail}.h5"),
                                  "normal_signal": str(Path(R) / "shear_pwave" / f"{stail}.h5"),
                                  "picks": str(Path(R) / "shear" / f"{stail}.json")}}
                if not Path(sample["out"]["picks"]).exists():
                    run_shear_sample(sample, log=lambda line: None)
                picks.append(sample["out"]["picks"])
                print(f"{stail}: {time.process_time() - t0:.1f} CPU-s", flush=True)
    if args.pressures:
        return
    records = [json.loads(Path(path).read_text()) for path in picks]
    good = [r for r in records if not r.get("error")]
    result = shear_scene(good, pick=sh.get("pick", "cross_correlation"),
                         material=sh.get("material", "glass"), diameter_mm=sh.get("diameter_mm", 1.0))
    result.update(scene=args.scene, source_scene=src, n_skipped=len(records) - len(good))
    out = Path(R) / "shear" / args.scene / "analysis.json"
    atomic_text(out, json.dumps(jsonable(result), indent=1) + "\n")
    print(f"wrote {out}: {len(good)} packings", file=sys.stderr)


if __name__ == "__main__":
    main()
