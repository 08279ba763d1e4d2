# Compiling the kernels once. On a cold numba cache (a fresh clone, a new machine, any change
# to granwave) every job would compile the kernels it uses, and jobs that start together
# compile the same ones at once. One warm-up job per kernel family runs tiny copies of the
# samples first; the jobs that use a family wait for it. The marker is ancient(): a finished
# warm-up never makes the jobs after it out of date.


def warm_up_samples():
    """One sample per scene, its cheapest to make (fewest grains, then highest pressure):
    the warm-ups run these, the lattices and chains shrunk further."""
    best = {}
    for _name, scene, samples in batches():
        for s in samples:
            key = (s["make"].get("grains", s["make"].get("n_balls", s["make"].get("rows", 0))),
                   -float(s["pressure"]))
            if scene not in best or key < best[scene][0]:
                best[scene] = (key, s)
    return [s for _key, s in best.values()]


def kernels_marker(family):
    return ancient(f"{R}/kernels/{family}.json")


def kernels_of(scene):
    """The warm-up markers a scene's batches wait for (a shear scene: the time domain's)."""
    if scene in shear_scenes():
        return [kernels_marker("linear")]
    if scene_kind(scene) in ("disordered", "continuum"):
        return [kernels_marker("dem"), kernels_marker("linear")]
    return [kernels_marker("linear")]


rule compile_kernels:
    conda:
        "../envs/granwave.yaml"
    output:
        f"{R}/kernels/{{family}}.json",
    log:
        f"{R}/logs/kernels/{{family}}.log",
    benchmark:
        f"{R}/benchmarks/kernels/{{family}}.tsv"
    wildcard_constraints:
        family="dem|linear",
    params:
        samples=lambda w: warm_up_samples(),
        pulse=lambda w: {"scene": config["damping"]["scene"], "ic": config["ic"],
                         "damping": max(config["damping"]["zetas"])}
        if config["damping"]["enabled"] else None,
    threads: 1
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/compile_kernels.py"
