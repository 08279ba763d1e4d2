# Per-sample measurements, their one-file summaries, and the per-scene analyses:
# height series (c_tof, gamma, alpha), ensembles, spectra and the pressure sweep.


STATICS_LAYER = 3.0


def sample_height(scene, size):
    """Nominal container height of a sample (rows of a lattice are sqrt(3)/2 apart)."""
    value = float(size[1:])
    return value * math.sqrt(3.0) / 2.0 if size[0] == "r" else value


rule statics:
    input:
        f"{R}/packing/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/statics/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.json",
    log:
        f"{R}/logs/statics/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    resources:
        runtime=5,
    shell:
        "granwave analyze statics {input} --layer {STATICS_LAYER} --json > {output} 2> {log}"


rule front:
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
    input:
        f"{R}/packing/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/moduli/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.json",
    log:
        f"{R}/logs/moduli/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    resources:
        mem_mb=2000,
        runtime=10,
    shell:
        "granwave analyze moduli {input} --local --json > {output} 2> {log}"


def summary_inputs(wildcards):
    kind = scene_kind(wildcards.scene)
    tail = f"{wildcards.scene}/p{wildcards.pressure}/{wildcards.size}/s{wildcards.seed}"
    inputs = {"front": f"{R}/front/{tail}.json"}
    if kind in ("disordered", "lattices"):
        # Bulk statics exclude 3 d at each wall (SPEC §4): only containers with a bulk have them.
        if sample_height(wildcards.scene, wildcards.size) > 2 * STATICS_LAYER + 1:
            inputs["statics"] = f"{R}/statics/{tail}.json"
        if scene_spec(wildcards.scene).get("moduli", True):
            inputs["moduli"] = f"{R}/moduli/{tail}.json"
    return inputs


rule summary:
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


def height_signals(wildcards):
    return sample_paths("signal", wildcards.scene, pressure=wildcards.pressure)


rule heights:
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


def sweep_inputs(wildcards):
    inputs = {"summaries": sample_paths("summary", wildcards.scene, ext="json")}
    inputs["heights"] = [f"{R}/heights/{wildcards.scene}/p{p}.json"
                         for p in pressures(wildcards.scene) if len(sizes(wildcards.scene, p)) >= 2]
    return inputs


rule pressure_sweep:
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
