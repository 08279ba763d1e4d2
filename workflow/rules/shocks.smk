# The shocks scenes (docs/shocks.md, "The shocks scene"; issue #63 item 3): 2D packings of one
# law and friction per scene, each pushed by a piston at constant velocity at every drive
# (the nonlinear DEM pulse, granwave.dem.pulse); per scene the front speed against the strain,
# its collapse V/c0 against eps/delta0, the crossover strain against p, the strongly nonlinear
# exponent and the contact fractions (granwave analyze shocks), its figure and report section.
# Included from the Snakefile only when the config has a shocks section (config/shocks.yaml).


rule shocks_kernels:
    conda:
        "../envs/granwave.yaml"
    output:
        f"{R}/kernels/shocks.json",
    log:
        f"{R}/logs/kernels/shocks.log",
    params:  # unrecorded: it follows the config's scenes (common.smk unrecorded)
        sample=lambda w: unrecorded(shocks_batches()[0][2][0]),
    threads: 1
    priority: 100
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/shocks_kernels.py"


for _name, _scene, _samples in shocks_batches():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        input:
            ancient(f"{R}/kernels/shocks.json"),
        output:
            [path for s in _samples for path in s["out"].values()],
            timings=f"{R}/timings/shocks/{_name}.tsv",
        log:
            f"{R}/logs/batch/{_name}.log",
        benchmark:
            f"{R}/benchmarks/shocks/{_name}.tsv"
        params:
            samples=_samples,
        threads: 1
        priority: 26
        resources:
            mem_mb=2000,
            runtime=120,
        script:
            "../scripts/shocks_batch.py"


rule shocks_analysis:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: shocks_records(w.scene),
    output:
        f"{R}/shocks/{{scene}}/analysis.json",
    log:
        f"{R}/logs/shocks/{{scene}}/analysis.log",
    params:
        tail_from=lambda w: config["shocks"][w.scene]["tail_from"],
    resources:
        runtime=5,
    shell:
        "granwave analyze shocks {input} --tail-from {params.tail_from} --json > {output} 2> {log}"


rule figure_shocks:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/shocks/{{scene}}/analysis.json",
    output:
        f"{F}/shocks_{{scene}}.png",
    log:
        f"{R}/logs/figures/shocks_{{scene}}.log",
    shell:
        "granwave plot shocks {input} --scene {wildcards.scene} -o {output} > {log} 2>&1"
