# Batches: the whole per-sample pipeline (make the sample, linearize, signal, statics,
# moduli, front, summary) of up to `batch_size` samples in one job, i.e. one Python process.
# Measured: a `granwave` command costs ~1 s of start-up (interpreter, imports, numba cache),
# more than most per-sample stages themselves (config/README.md).
#
# One rule per batch with its files named explicitly: the per-sample files keep their
# names, and Snakemake prefers a rule without wildcards over the per-sample rules of
# packings.smk / linear.smk / analysis.smk, which still make any single file on request
# (e.g. the modes of the spectrum figure).


def batch_sample(scene, p, size, seed):
    """What workflow/scripts/sample_batch.py needs for one sample (options and paths)."""
    kind, spec = scene_kind(scene), scene_spec(scene)
    tail = f"{scene}/p{p}/{size}/s{seed}"
    if kind == "disordered":
        height = float(size[1:])
        make = dict(dim=spec["dim"], grains=grain_count(spec, height),
                    aspect=float(f"{height / spec['width']:.6g}"), pressure=float(p),
                    friction=float(spec["friction"]), poisson=float(spec["poisson"]),
                    polydispersity=float(spec["polydispersity"]), tol=float(spec["tol"]),
                    max_steps=int(spec["max_steps"]), seed=seed)
    elif kind == "lattices":
        make = dict(rows=int(size[1:]), width=int(spec["width"]), pressure=float(p),
                    friction=float(spec["friction"]), poisson=float(spec["poisson"]))
    else:
        make = dict(n_balls=int(size[1:]), pressure=float(p),
                    polydispersity=float(spec["polydispersity"]), seed=seed)
    wc = SimpleNamespace(scene=scene, pressure=p, size=size, seed=seed)
    out = {stage: f"{R}/{stage}/{tail}.h5" for stage in ("packing", "linear", "signal")}
    for stage in summary_inputs(wc):  # front, and statics / moduli where the scene has them
        out[stage] = f"{R}/{stage}/{tail}.json"
    out["summary"] = f"{R}/summary/{tail}.json"
    return {"kind": kind, "scene": scene, "pressure": p, "size": size, "seed": seed, "make": make,
            "signal": {"method": signal_method(scene), "ic": ic_of(scene),
                       "t_max": float(f"{t_max(wc):.6g}"), "samples": config["samples"]},
            "out": out}


def batches():
    """[(name, scene, samples)]: every scene's samples in order, cut into batch_size pieces."""
    out = []
    for scene in scenes():
        items = samples(scene)
        for k in range(0, len(items), config["batch_size"]):
            out.append((f"batch_{scene}_{k // config['batch_size']}", scene,
                        [batch_sample(scene, *s) for s in items[k:k + config["batch_size"]]]))
    return out


for _name, _scene, _samples in batches():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        output:
            [path for s in _samples for path in s["out"].values()],
            timings=f"{R}/timings/{_name}.tsv",
        log:
            f"{R}/logs/batch/{_name}.log",
        benchmark:
            f"{R}/benchmarks/batch/{_name}.tsv"
        params:
            samples=_samples,
        threads: 1
        resources:
            mem_mb=2000,
            runtime=60,
        script:
            "../scripts/sample_batch.py"
