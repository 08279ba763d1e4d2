# Samples: DEM packings (prepare-packing), perfect lattices and chains.


def prepare_args(wildcards):
    """prepare-packing options for one sample: the grain count sets the height at fixed width."""
    spec = scene_spec(wildcards.scene)
    height = float(wildcards.height)
    n = grain_count(spec, height)
    return (f"--dim {spec['dim']} --grains {n} --aspect {height / spec['width']:.6g} "
            f"--pressure {wildcards.pressure} --friction {spec['friction']} "
            f"--poisson {spec['poisson']} --polydispersity {spec['polydispersity']} "
            f"--tol {spec['tol']:g} --max-steps {spec['max_steps']} --seed {wildcards.seed}")


rule prepare_packing:
    output:
        f"{R}/packing/{{scene}}/p{{pressure}}/h{{height}}/s{{seed}}.h5",
    log:
        f"{R}/logs/packing/{{scene}}/p{{pressure}}/h{{height}}/s{{seed}}.log",
    params:
        args=prepare_args,
    threads: 1
    resources:
        mem_mb=1000,
        runtime=60,
    shell:
        "granwave prepare-packing {params.args} --quiet -o {output} > {log} 2>&1"


rule make_lattice:
    output:
        f"{R}/packing/{{scene}}/p{{pressure}}/r{{rows}}/s0.h5",
    log:
        f"{R}/logs/packing/{{scene}}/p{{pressure}}/r{{rows}}/s0.log",
    params:
        spec=lambda w: scene_spec(w.scene),
    resources:
        mem_mb=500,
        runtime=5,
    shell:
        "granwave lattice --rows {wildcards.rows} --width {params.spec[width]} "
        "--pressure {wildcards.pressure} --friction {params.spec[friction]} "
        "--poisson {params.spec[poisson]} -o {output} > {log} 2>&1"


rule make_chain:
    output:
        f"{R}/packing/{{scene}}/p{{pressure}}/n{{balls}}/s{{seed}}.h5",
    log:
        f"{R}/logs/packing/{{scene}}/p{{pressure}}/n{{balls}}/s{{seed}}.log",
    params:
        spec=lambda w: scene_spec(w.scene),
    resources:
        mem_mb=500,
        runtime=5,
    shell:
        "granwave chain --balls {wildcards.balls} --pressure {wildcards.pressure} "
        "--polydispersity {params.spec[polydispersity]} --seed {wildcards.seed} "
        "-o {output} > {log} 2>&1"
