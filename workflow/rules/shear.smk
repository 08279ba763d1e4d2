# The shear scenes (docs/shear.md, "The shear scene"; issue #49 item 4): the packings of a
# frictional disordered scene kicked along x (shear) and along y (compressional), both as
# impulses in the time domain, every bender-element pick at each source wavelength; per scene
# V_s(p), V_p(p), G_max(p) against p^(1/3), V_p/V_s and the Poisson ratio from waves and from
# the moduli, and the pick table. The source scene's batches make the linear systems and
# moduli; one batch job runs many packings (each ~1 CPU-s) in one process.


for _name, _scene, _samples in shear_batches():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        input:
            kernels_of(_scene),
            [path for s in _samples for path in s["in"].values()],
        output:
            [path for s in _samples for path in s["out"].values()],
            timings=f"{R}/timings/shear/{_name}.tsv",  # not timings/: benchmarks/workflow_runtime.py models the sample batches only
        log:
            f"{R}/logs/batch/{_name}.log",
        benchmark:
            f"{R}/benchmarks/shear/{_name}.tsv"
        params:
            samples=_samples,
        threads: 1
        priority: 26  # as the sample extras: its analysis and figure, then the report, wait for it
        resources:
            mem_mb=2000,
            runtime=60,
        script:
            "../scripts/shear_batch.py"


rule shear_analysis:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: shear_picks(w.scene),
    output:
        f"{R}/shear/{{scene}}/analysis.json",
    log:
        f"{R}/logs/shear/{{scene}}/analysis.log",
    params:
        pick=lambda w: config["shear"][w.scene]["pick"],
        source=lambda w: config["shear"][w.scene]["scene"],
        material=lambda w: config["shear"][w.scene]["material"],
        diameter_mm=lambda w: config["shear"][w.scene]["diameter_mm"],
        poisson=lambda w: float(scene_spec(config["shear"][w.scene]["scene"])["poisson"]),  # the packings' nu
    resources:
        runtime=5,
    script:
        "../scripts/shear_analysis.py"


rule figure_shear:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/shear/{{scene}}/analysis.json",
    output:
        f"{F}/shear_{{scene}}.png",
    log:
        f"{R}/logs/figures/shear_{{scene}}.log",
    shell:
        "granwave plot shear {input} --scene {wildcards.scene} -o {output} > {log} 2>&1"


# The analysis and its figure in one process, at the end of the run where every second of
# start-up is on the critical path (rules shear_analysis and figure_shear make them alone).
use rule shear_analysis as shear_scene_outputs with:
    output:
        analysis=f"{R}/shear/{{scene}}/analysis.json",
        figure=f"{F}/shear_{{scene}}.png",


ruleorder: shear_scene_outputs > shear_analysis
ruleorder: shear_scene_outputs > figure_shear
