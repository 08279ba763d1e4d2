# The linear pipeline of every sample: linearize -> eigensolve -> propagate (modal).


rule linearize:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/packing/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/linear/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    log:
        f"{R}/logs/linear/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    benchmark:
        f"{R}/benchmarks/linear/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    shell:
        "granwave linearize --threads {threads} {input} -o {output} > {log} 2>&1"


rule eigensolve:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/linear/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/modes/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    log:
        f"{R}/logs/modes/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    benchmark:
        f"{R}/benchmarks/modes/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.tsv"
    threads: 1
    resources:
        mem_mb=4000,
        runtime=30,
    shell:
        "granwave eigensolve --threads {threads} {input} -o {output} > {log} 2>&1"


rule propagate:
    conda:
        "../envs/granwave.yaml"
    input:
        propagate_input,
    output:
        f"{R}/signal/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    log:
        f"{R}/logs/signal/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    benchmark:
        f"{R}/benchmarks/signal/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.tsv"
    params:
        ic=lambda w: ic_of(w.scene),
        method=lambda w: solver_of(w.scene),
        t_max=t_max,
        samples=config["samples"],
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    shell:
        "granwave propagate --threads {threads} {input} --method {params.method} --ic {params.ic} --t-max {params.t_max:.6g} "
        "--samples {params.samples} -o {output} > {log} 2>&1"
