# Compiling the kernels once. On a cold numba cache (a fresh clone, a new machine, any change
# to granwave) every job would compile the kernels it uses, and jobs that start together
# compile the same ones at once. One warm-up job per kernel family runs tiny copies of the
# samples first; the jobs that use a family wait for it. The marker is ancient(): a finished
# warm-up never makes the jobs after it out of date. Helpers: common.smk.


rule compile_kernels:
    conda:
        "../envs/granwave.yaml"
    input:
        [],
    output:
        f"{R}/kernels/{{family}}.json",
    log:
        f"{R}/logs/kernels/{{family}}.log",
    benchmark:
        f"{R}/benchmarks/kernels/{{family}}.tsv"
    wildcard_constraints:
        family="dem|linear",  # pulse: the rule below
    params:  # unrecorded: they follow the config's scenes (common.smk unrecorded)
        samples=lambda w: unrecorded(warm_up_samples()),
        pulse=lambda w: unrecorded({"scene": config["damping"]["scene"], "ic": config["ic"],
                                    "damping": max(config["damping"]["zetas"])}
                                   if config["damping"]["enabled"] else None),
    threads: 1
    priority: 100  # before everything that waits for it
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/compile_kernels.py"


# The DEM pulse's kernels. On a 2D scene they are compiled on a small perfect lattice (no DEM
# preparation: granwave.workflow_support.pulse_on_lattice), on the core that the DEM-free
# reference batches free while "dem" still compiles (priority below theirs, common.smk
# batch_priority); by then "dem" has cached the force loop the pulse calls. A 3D scene needs
# a DEM packing, so its pulse warm-up waits for "dem".
use rule compile_kernels as compile_pulse_kernels with:
    input:
        [] if pulse_warm_up_on_lattice() else [kernels_marker("dem")],
    wildcard_constraints:
        family="pulse",
    priority: 30
