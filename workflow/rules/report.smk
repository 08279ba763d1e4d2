# Figures of the study and the final report (results/report/index.md).

# The main study's figures in one job (one process; a `granwave plot` command costs ~2-3 s of
# start-up, matplotlib included). This rule comes first for the figures it makes (asking for one
# runs the whole job); the rules figure_airy ... figure_speeds below remain, with the same options.
for _name, _commands in study_figures():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        input:
            sorted({path for c in _commands for path in c["in"]}),
        output:
            [c["out"]["result"] for c in _commands],
            timings=f"{R}/timings/analyses/{_name}.tsv",
        log:
            f"{R}/logs/figures/{_name}.log",
        benchmark:
            f"{R}/benchmarks/analyses/{_name}.tsv"
        params:
            commands=_commands,
        threads: 1
        resources:
            mem_mb=1000,
            runtime=10,
        script:
            "../scripts/analysis_batch.py"


# The main sample's spectrum, mode shapes, snapshot signal and damping pulses with their figures
# in one job, and each continuum scene's two analyses and figure in one job (one process each:
# common.smk main_sample_extras and continuum_jobs). As above, these rules win over the per-file
# rules below (no wildcards, or ruleorder), which remain for any single file asked for alone.
for _name, _commands in main_sample_extras() + continuum_jobs():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        input:
            sorted({path for c in _commands for path in c["in"]}),
        output:
            [c["out"]["result"] for c in _commands],
            timings=f"{R}/timings/analyses/{_name}.tsv",
        log:
            f"{R}/logs/analyses/{_name}.log",
        benchmark:
            f"{R}/benchmarks/analyses/{_name}.tsv"
        params:
            commands=_commands,
        threads: 1
        # after the batches with the most DEM work (28 in the quick config), before the others:
        # only the report waits for these jobs (~15-20 CPU-s each in the quick run), and with
        # priority 0 they ran after every batch and made the run's tail (measured 2026-11-28)
        priority: 26
        resources:
            mem_mb=4000,
            runtime=60,
        script:
            "../scripts/analysis_batch.py"


ruleorder: figures_study > figure_airy
ruleorder: figures_study > figure_signals
ruleorder: figures_study > figure_coherent
ruleorder: figures_study > figure_compare
ruleorder: figures_study > figure_arrivals
ruleorder: figures_study > figure_exponents
ruleorder: figures_study > figure_speeds
if main_sample_extras():  # a config without a disordered scene or damping has no such job

    ruleorder: sample_extras > figure_spectrum
    ruleorder: sample_extras > figure_modes
    ruleorder: sample_extras > figure_snapshot
    ruleorder: sample_extras > figure_damping
    ruleorder: sample_extras > damping_table


rule figure_network:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: first_sample_path("packing", main_sample()[0]),
    output:
        f"{F}/{{kind}}.png",
    log:
        f"{R}/logs/figures/{{kind}}.log",
    wildcard_constraints:
        kind="network|roses",
    params:
        scene=lambda w: main_sample()[0],
    shell:
        "granwave plot {wildcards.kind} {input} --scene {params.scene} -o {output} > {log} 2>&1"


rule figure_signals:
    conda:
        "../envs/granwave.yaml"
    input:
        signals=lambda w: sample_paths("signal", main_sample()[0], pressure=main_sample()[1],
                                       size=main_sample()[2]),
        ensemble=lambda w: f"{R}/ensemble/{main_sample()[0]}/p{main_sample()[1]}/{main_sample()[2]}.h5",
    output:
        f"{F}/signals.png",
    log:
        f"{R}/logs/figures/signals.log",
    params:
        scene=lambda w: main_sample()[0],
    shell:
        "granwave plot signals {input.signals} --ensemble {input.ensemble} --scene {params.scene} -o {output} > {log} 2>&1"


rule figure_coherent:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: [f"{R}/ensemble/{main_sample()[0]}/p{main_sample()[1]}/{sz}.h5"
                   for sz in sizes(main_sample()[0], main_sample()[1])],
    output:
        f"{F}/coherent.png",
    log:
        f"{R}/logs/figures/coherent.log",
    params:
        scene=lambda w: main_sample()[0],
    shell:
        "granwave plot coherent {input} --scene {params.scene} -o {output} > {log} 2>&1"


rule figure_compare:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: [first_sample_path("signal", s) for s in scenes("disordered")],
    output:
        f"{F}/compare.png",
    log:
        f"{R}/logs/figures/compare.log",
    params:
        labels=lambda w: flags("--label", scenes("disordered")),
    shell:
        "granwave plot compare {input} {params.labels} -o {output} > {log} 2>&1"


rule figure_arrivals:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: f"{R}/heights/{main_sample()[0]}/p{main_sample()[1]}.json",
    output:
        f"{F}/arrivals.png",
    log:
        f"{R}/logs/figures/arrivals.log",
    params:
        scene=lambda w: main_sample()[0],
    shell:
        "granwave plot arrivals {input} --scene {params.scene} -o {output} > {log} 2>&1"


rule figure_exponents:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: [path for scene, path in exponent_series() if scene_kind(scene) != "chains"],
    output:
        f"{F}/exponents.png",
    log:
        f"{R}/logs/figures/exponents.log",
    params:
        labels=lambda w: flags("--label", [scene for scene, _ in exponent_series()
                                           if scene_kind(scene) != "chains"]),
    shell:
        "granwave plot exponents {input} {params.labels} -o {output} > {log} 2>&1"


rule figure_speeds:
    conda:
        "../envs/granwave.yaml"
    input:
        sweep=lambda w: f"{R}/sweep/{main_sample()[0]}.json",
        frictionless=lambda w: lattice_heights(False),
        frictional=lambda w: lattice_heights(True),
    output:
        f"{F}/speeds.png",
    log:
        f"{R}/logs/figures/speeds.log",
    params:
        scene=lambda w: main_sample()[0],
        lattices=lambda w, input: lattice_flags(input),
    shell:
        "granwave plot speeds {input.sweep} {params.lattices} --scene {params.scene} -o {output} > {log} 2>&1"


rule figure_spectrum:
    conda:
        "../envs/granwave.yaml"
    input:
        lambda w: first_sample_path("modes", main_sample()[0]),
    output:
        f"{F}/spectrum.png",
    log:
        f"{R}/logs/figures/spectrum.log",
    params:
        scene=lambda w: main_sample()[0],
    shell:
        "granwave plot spectrum {input} --scene {params.scene} -o {output} > {log} 2>&1"


rule eigensolve_vectors:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/linear/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/modes_vectors/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    log:
        f"{R}/logs/modes_vectors/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    resources:
        mem_mb=4000,
        runtime=30,
    shell:
        "granwave eigensolve {input} --vectors -o {output} > {log} 2>&1"


rule figure_modes:
    conda:
        "../envs/granwave.yaml"
    input:
        modes=lambda w: first_sample_path("modes_vectors", main_sample()[0]),
        linear=lambda w: first_sample_path("linear", main_sample()[0]),
        packing=lambda w: first_sample_path("packing", main_sample()[0]),
    output:
        f"{F}/modes.png",
    log:
        f"{R}/logs/figures/modes.log",
    params:
        scene=lambda w: main_sample()[0],
    shell:
        "granwave plot modes {input.modes} {input.linear} {input.packing} --scene {params.scene} -o {output} > {log} 2>&1"


rule snapshot_signal:
    conda:
        "../envs/granwave.yaml"
    input:
        f"{R}/linear/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/snapshots/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    log:
        f"{R}/logs/snapshots/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    params:
        ic=config["ic"],
        t_max=t_max,
        times=lambda w: ",".join(f"{t:.6g}" for t in snapshot_times(w)),
    resources:
        runtime=10,
    shell:
        "granwave propagate {input} --method time --ic {params.ic} --t-max {params.t_max:.6g} "
        "--snapshots {params.times} -o {output} > {log} 2>&1"


rule figure_snapshot:
    conda:
        "../envs/granwave.yaml"
    input:
        signal=lambda w: first_sample_path("snapshots", main_sample()[0]),
        packing=lambda w: first_sample_path("packing", main_sample()[0]),
        modes=lambda w: first_sample_path("modes_vectors", main_sample()[0]),
        linear=lambda w: first_sample_path("linear", main_sample()[0]),
    output:
        f"{F}/snapshot.png",
    log:
        f"{R}/logs/figures/snapshot.log",
    params:
        scene=lambda w: main_sample()[0],
    shell:
        "granwave plot snapshot {input.signal} --packing {input.packing} --modes {input.modes} "
        "--linear {input.linear} --scene {params.scene} -o {output} > {log} 2>&1"


rule figure_airy:
    conda:
        "../envs/granwave.yaml"
    output:
        f"{F}/airy.png",
    log:
        f"{R}/logs/figures/airy.log",
    shell:
        "granwave plot airy --n 100 --n 400 --n 1600 -o {output} > {log} 2>&1"


rule report:
    conda:
        "../envs/granwave.yaml"
    input:
        summaries=all_summaries(),
        heights=all_height_series(),
        sweeps=sweep_paths(),
        figures=figure_targets(),
        ensembles=[f"{R}/ensemble/{s}/p{p}/{sz}.json" for s in scenes("disordered")
                   for p in pressures(s) for sz in sizes(s, p)],
        spectra=[first_sample_path("spectrum", s, ext="json") for s in scenes("disordered")
                 if scene_spec(s).get("spectrum")],
        damping=[f"{R}/damping/table.json"] if config["damping"]["enabled"] else [],
        continuum=continuum_outputs(),
        shear=shear_outputs(),
        shocks=shocks_outputs(),
        timings=all_timings(),
    output:
        md=f"{R}/report/index.md",
        html=f"{R}/report/index.html",
    log:
        f"{R}/logs/report.log",
    params:
        config=workflow.configfiles[-1] if workflow.configfiles else "config/config.yaml",
        args=lambda w, input: " ".join([flags("--summaries", input.summaries),
                                        flags("--heights", input.heights),
                                        flags("--sweep", input.sweeps),
                                        flags("--figures", input.figures),
                                        flags("--damping", input.damping),
                                        flags("--continuum", input.continuum),
                                        flags("--shear", input.shear),
                                        flags("--shocks", input.shocks),
                                        flags("--timings", input.timings)]),
    shell:
        "granwave report --config {params.config} {params.args} -o {output.md} > {log} 2>&1"


rule damping_signal:
    conda:
        "../envs/granwave.yaml"
    input:
        packing=lambda w: damping_packing(),
        kernels=kernels_marker("pulse"),
    output:
        f"{R}/damping/zeta{{zeta}}.h5",
    log:
        f"{R}/logs/damping/zeta{{zeta}}.log",
    benchmark:
        f"{R}/benchmarks/damping/zeta{{zeta}}.tsv"
    params:
        t_max=lambda w: damping_t_max(),
        ic=config["ic"],
        amplitude=config["damping"]["amplitude"],
        samples=config["samples"],
    resources:
        runtime=60,
    shell:
        "granwave propagate {input.packing} --method dem --ic {params.ic} --damping {wildcards.zeta} "
        "--amplitude {params.amplitude} --t-max {params.t_max:.6g} --samples {params.samples} "
        "-o {output} > {log} 2>&1"


rule damping_table:
    conda:
        "../envs/granwave.yaml"
    input:
        [f"{R}/damping/zeta{z:g}.h5" for z in config["damping"]["zetas"]],
    output:
        f"{R}/damping/table.json",
    log:
        f"{R}/logs/damping/table.log",
    shell:
        "granwave analyze damping {input} --json > {output} 2> {log}"


rule figure_damping:
    conda:
        "../envs/granwave.yaml"
    input:
        signals=[f"{R}/damping/zeta{z:g}.h5" for z in config["damping"]["zetas"]],
        reference=lambda w: damping_linear_reference(),
    output:
        f"{F}/damping.png",
    log:
        f"{R}/logs/figures/damping.log",
    params:
        scene=config["damping"]["scene"],
    shell:
        "granwave plot damping {input.signals} --reference {input.reference} --scene {params.scene} -o {output} > {log} 2>&1"
