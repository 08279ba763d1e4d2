# The continuum scene (docs/continuum.md): per scene, the front against distance and its
# approach to each packing's own c_l (granwave analyze continuum), and the attenuation and
# phase velocity of the coherent signal (granwave analyze attenuation). The samples
# themselves are made by the batches (rules/batches.smk), time-domain signals and
# global moduli.


rule continuum_front:
    conda:
        "../envs/granwave.yaml"
    input:
        signals=lambda w: sample_paths("signal", w.scene),
        moduli=lambda w: sample_paths("moduli", w.scene, ext="json"),
    output:
        f"{R}/continuum/{{scene}}/front.json",
    log:
        f"{R}/logs/continuum/{{scene}}/front.log",
    params:
        moduli=lambda w, input: flags("--moduli", input.moduli),
    resources:
        runtime=10,
    shell:
        "granwave analyze continuum {input.signals} {params.moduli} --json > {output} 2> {log}"


rule continuum_attenuation:
    conda:
        "../envs/granwave.yaml"
    input:
        signals=lambda w: sample_paths("signal", w.scene),
        moduli=lambda w: sample_paths("moduli", w.scene, ext="json"),
    output:
        f"{R}/continuum/{{scene}}/attenuation.json",
    log:
        f"{R}/logs/continuum/{{scene}}/attenuation.log",
    params:
        bootstrap=lambda w: scene_spec(w.scene)["bootstrap"],
        moduli=lambda w, input: flags("--moduli", input.moduli),
        width=lambda w: scene_spec(w.scene)["width"],  # nominal lateral period (d) of the cutoff
    resources:
        runtime=10,
    shell:
        "granwave analyze attenuation {input.signals} --bootstrap {params.bootstrap} {params.moduli} "
        "--lateral-period {params.width} --json > {output} 2> {log}"


rule figure_continuum:
    conda:
        "../envs/granwave.yaml"
    input:
        front=f"{R}/continuum/{{scene}}/front.json",
        attenuation=f"{R}/continuum/{{scene}}/attenuation.json",
    output:
        f"{F}/continuum_{{scene}}.png",
    log:
        f"{R}/logs/figures/continuum_{{scene}}.log",
    shell:
        "granwave plot continuum {input.front} --attenuation {input.attenuation} --scene {wildcards.scene} -o {output} "
        "> {log} 2>&1"
