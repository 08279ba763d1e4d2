# Samples: DEM packings (prepare-packing), perfect lattices and chains.

rule prepare_packing:
    conda:
        "../envs/granwave.yaml"
    output:
        f"{R}/packing/{{scene}}/p{{pressure}}/h{{height}}/s{{seed}}.h5",
    log:
        f"{R}/logs/packing/{{scene}}/p{{pressure}}/h{{height}}/s{{seed}}.log",
    benchmark:
        f"{R}/benchmarks/packing/{{scene}}/p{{pressure}}/h{{height}}/s{{seed}}.tsv"
    params:
        args=prepare_args,
        checkpoint=checkpoint_args,
    threads: packing_threads
    resources:
        mem_mb=1000,
        runtime=60,
    shell:
        "{params.checkpoint[0]}granwave prepare-packing --threads {threads} {params.args} {params.checkpoint[1]} "
        "--quiet -o {output} > {log} 2>&1"


rule make_lattice:
    conda:
        "../envs/granwave.yaml"
    output:
        f"{R}/packing/{{scene}}/p{{pressure}}/r{{rows}}/s0.h5",
    log:
        f"{R}/logs/packing/{{scene}}/p{{pressure}}/r{{rows}}/s0.log",
    params:
        spec=lambda w: scene_spec(w.scene),
        contact=contact_args,
    resources:
        mem_mb=500,
        runtime=5,
    shell:
        "granwave lattice --rows {wildcards.rows} --width {params.spec[width]} "
        "--pressure {wildcards.pressure} --friction {params.spec[friction]} "
        "--poisson {params.spec[poisson]} {params.contact} -o {output} > {log} 2>&1"


rule make_chain:
    conda:
        "../envs/granwave.yaml"
    output:
        f"{R}/packing/{{scene}}/p{{pressure}}/n{{balls}}/s{{seed}}.h5",
    log:
        f"{R}/logs/packing/{{scene}}/p{{pressure}}/n{{balls}}/s{{seed}}.log",
    params:
        spec=lambda w: scene_spec(w.scene),
        contact=contact_args,
    resources:
        mem_mb=500,
        runtime=5,
    shell:
        "granwave chain --balls {wildcards.balls} --pressure {wildcards.pressure} "
        "--polydispersity {params.spec[polydispersity]} --seed {wildcards.seed} "
        "{params.contact} -o {output} > {log} 2>&1"
