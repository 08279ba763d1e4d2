# Compiling the kernels once. On a cold numba cache (a fresh clone, a new machine, any change
# to granwave) every job would compile the kernels it uses, and jobs that start together
# compile the same ones at once. One warm-up job per kernel family runs tiny copies of the
# samples first; the jobs that use a family wait for it. The marker is ancient(): a finished
# warm-up never makes the jobs after it out of date. Helpers: common.smk.


rule compile_kernels:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: [kernels_marker("dem")] if w.family == "pulse" else [],  # the pulse calls dem's force loop
    output:
        f"{R}/kernels/{{family}}.json",
    log:
        f"{R}/logs/kernels/{{family}}.log",
    benchmark:
        f"{R}/benchmarks/kernels/{{family}}.tsv"
    wildcard_constraints:
        family="dem|pulse|linear",  # continuum: the rule below
    params:
        samples=lambda w: warm_up_samples(),
        pulse=lambda w: {"scene": config["damping"]["scene"], "ic": config["ic"],
                         "damping": max(config["damping"]["zetas"])}
        if config["damping"]["enabled"] else None,
    threads: 1
    priority: 100  # before everything that waits for it
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/compile_kernels.py"


# The continuum samples' preparation adds one run loop (the mean-flow rule's) to what "dem"
# compiles. Its warm-up starts when a core is free of the first jobs (priority below the
# DEM-free reference batches, common.smk batch_priority), by which time "dem" has cached the
# kernels the two share; "dem", which every preparation waits for, ends that much earlier.
use rule compile_kernels as compile_continuum_kernels with:
    input:
        [],
    wildcard_constraints:
        family="continuum",
    priority: 30
