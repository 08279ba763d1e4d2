# Per-sample measurements, their one-file summaries, and the per-scene analyses:
# height series (c_tof, gamma, alpha), ensembles, spectra and the pressure sweep.

rule statics:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/packing/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/statics/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.json",
    log:
        f"{R}/logs/statics/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    resources:
        runtime=5,
    params:
        layer=STATICS_LAYER,
    shell:
        "granwave analyze statics {input} --layer {params.layer} --json > {output} 2> {log}"


rule front:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/signal/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/front/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.json",
    log:
        f"{R}/logs/front/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    resources:
        runtime=5,
    shell:
        "granwave analyze front {input} --json > {output} 2> {log}"


rule moduli:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/packing/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/moduli/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.json",
    log:
        f"{R}/logs/moduli/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    benchmark:
        f"{R}/benchmarks/moduli/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.tsv"
    params:
        local=moduli_args,
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    shell:
        "granwave analyze moduli --threads {threads} {input} {params.local} --json > {output} 2> {log}"


rule summary:
    conda:
        "../envs/granwave.yaml"
    input:
        unpack(summary_inputs),
        signal=f"{R}/signal/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/summary/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.json",
    log:
        f"{R}/logs/summary/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    resources:
        runtime=2,
    script:
        "../scripts/merge_summary.py"


# A scene's height series, ensembles and pressure sweep in one job (one process): each
# `granwave` command costs ~1-2 s of start-up, more than the analysis itself. As for the batches
# (rules/batches.smk), the files keep their names and Snakemake prefers these rules without
# wildcards (asking for one of their files runs the whole job); rules heights, ensemble and
# pressure_sweep below make the files outside them (e.g. a lattice scene's ensembles).
for _name, _scene, _commands in scene_analyses():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        input:
            sorted({path for c in _commands for path in c["in"]}),
        output:
            [directory(path) if key == "tables" else path for c in _commands for key, path in c["out"].items()],
            timings=f"{R}/timings/analyses/{_name}.tsv",
        log:
            f"{R}/logs/analyses/{_name}.log",
        benchmark:
            f"{R}/benchmarks/analyses/{_name}.tsv"
        params:
            commands=_commands,
        threads: 1
        # the lattices' and chains' analyses right after their batch, while the DEM kernels
        # compile (the figures wait for them: run last, they delayed the run's end)
        priority: 60 if _scene == "reference" else 0
        resources:
            mem_mb=2000,
            runtime=30,  # the paper config: a scene's thousands of signals, read twice
        script:
            "../scripts/analysis_batch.py"


rule heights:
    conda:
        "../envs/granwave.yaml"
    input:
        height_signals,
    output:
        f"{R}/heights/{{scene}}/p{{pressure}}.json",
    log:
        f"{R}/logs/heights/{{scene}}/p{{pressure}}.log",
    params:
        edges=",".join(f"{h:g}" for h in config["edge_heights"]),
    resources:
        runtime=5,
    shell:
        "granwave analyze heights {input} --edge-heights {params.edges} --json > {output} 2> {log}"


rule ensemble:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: sample_paths("signal", w.scene, pressure=w.pressure, size=w.size),
    output:
        h5=f"{R}/ensemble/{{scene}}/p{{pressure}}/{{size}}.h5",
        json=f"{R}/ensemble/{{scene}}/p{{pressure}}/{{size}}.json",
    log:
        f"{R}/logs/ensemble/{{scene}}/p{{pressure}}/{{size}}.log",
    resources:
        runtime=5,
    shell:
        "granwave analyze ensemble {input} -o {output.h5} --json > {output.json} 2> {log}"


rule spectrum:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/modes/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/spectrum/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.json",
    log:
        f"{R}/logs/spectrum/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    resources:
        runtime=5,
    shell:
        "granwave analyze spectrum {input} --json > {output} 2> {log}"


rule pressure_sweep:
    conda:
        "../envs/granwave.yaml"
    input:
        unpack(sweep_inputs),
    output:
        h5=f"{R}/sweep/{{scene}}.h5",
        json=f"{R}/sweep/{{scene}}.json",
        tables=directory(f"{R}/sweep/{{scene}}_tables"),
    log:
        f"{R}/logs/sweep/{{scene}}.log",
    resources:
        runtime=5,
    shell:
        "granwave pressure-sweep {input.summaries} {input.heights} -o {output.h5} "
        "--tables {output.tables} --json > {output.json} 2> {log}"
