# Figures of the study and the final report (results/report/index.md).

F = f"{R}/figures"


def main_sample():
    """The reference sample of the figures: the first disordered scene, highest pressure,
    tallest container, seed 0 (None when the config has no disordered scene)."""
    for scene in scenes("disordered"):
        p = pressures(scene)[-1]
        return scene, p, sizes(scene, p)[-1]
    return None


def first_sample_path(stage, scene, ext="h5"):
    p = pressures(scene)[-1]
    return sample_paths(stage, scene, ext=ext, pressure=p, size=sizes(scene, p)[-1])[0]


def height_series_paths(scene):
    return [f"{R}/heights/{scene}/p{p}.json" for p in pressures(scene) if len(sizes(scene, p)) >= 2]


def flags(flag, paths):
    return " ".join(f"{flag} {p}" for p in paths)


def figure_targets():
    figs = [f"{F}/airy.png"]
    if main_sample():
        figs += [f"{F}/network.png", f"{F}/roses.png", f"{F}/signals.png", f"{F}/coherent.png",
                 f"{F}/compare.png", f"{F}/modes.png", f"{F}/snapshot.png"]
        scene, p, _ = main_sample()
        if len(sizes(scene, p)) >= 2:
            figs.append(f"{F}/arrivals.png")
        if len(pressures(scene)) >= 2:
            figs.append(f"{F}/speeds.png")
        if scene_spec(scene).get("spectrum"):
            figs.append(f"{F}/spectrum.png")
    if any(height_series_paths(s) for s in scenes("disordered") + scenes("chains")):
        figs.append(f"{F}/exponents.png")
    if config["damping"]["enabled"]:
        figs.append(f"{F}/damping.png")
    return figs


def report_inputs():
    inputs = [f"{R}/report/index.md"]
    return inputs


rule figure_network:
    input:
        lambda w: first_sample_path("packing", main_sample()[0]),
    output:
        f"{F}/{{kind}}.png",
    log:
        f"{R}/logs/figures/{{kind}}.log",
    wildcard_constraints:
        kind="network|roses",
    shell:
        "granwave plot {wildcards.kind} {input} -o {output} > {log} 2>&1"


rule figure_signals:
    input:
        signals=lambda w: sample_paths("signal", main_sample()[0], pressure=main_sample()[1],
                                       size=main_sample()[2]),
        ensemble=lambda w: f"{R}/ensemble/{main_sample()[0]}/p{main_sample()[1]}/{main_sample()[2]}.h5",
    output:
        f"{F}/signals.png",
    log:
        f"{R}/logs/figures/signals.log",
    shell:
        "granwave plot signals {input.signals} --ensemble {input.ensemble} -o {output} > {log} 2>&1"


rule figure_coherent:
    input:
        lambda w: [f"{R}/ensemble/{main_sample()[0]}/p{main_sample()[1]}/{sz}.h5"
                   for sz in sizes(main_sample()[0], main_sample()[1])],
    output:
        f"{F}/coherent.png",
    log:
        f"{R}/logs/figures/coherent.log",
    shell:
        "granwave plot coherent {input} -o {output} > {log} 2>&1"


rule figure_compare:
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
    input:
        lambda w: f"{R}/heights/{main_sample()[0]}/p{main_sample()[1]}.json",
    output:
        f"{F}/arrivals.png",
    log:
        f"{R}/logs/figures/arrivals.log",
    shell:
        "granwave plot arrivals {input} -o {output} > {log} 2>&1"


def exponent_series():
    series = []
    for scene in scenes("disordered"):
        series += [(scene, path) for path in height_series_paths(scene)[-1:]]
    for scene in scenes("chains"):
        series += [(scene, path) for path in height_series_paths(scene)]
    return series


rule figure_exponents:
    input:
        lambda w: [path for _, path in exponent_series()],
    output:
        f"{F}/exponents.png",
    log:
        f"{R}/logs/figures/exponents.log",
    params:
        labels=lambda w: flags("--label", [scene for scene, _ in exponent_series()]),
    shell:
        "granwave plot exponents {input} {params.labels} -o {output} > {log} 2>&1"


def lattice_heights(frictional):
    return [path for scene in scenes("lattices")
            if (scene_spec(scene)["friction"] > 0) == frictional
            for path in height_series_paths(scene)]


rule figure_speeds:
    input:
        sweep=lambda w: f"{R}/sweep/{main_sample()[0]}.json",
        frictionless=lambda w: lattice_heights(False),
        frictional=lambda w: lattice_heights(True),
    output:
        f"{F}/speeds.png",
    log:
        f"{R}/logs/figures/speeds.log",
    params:
        lattices=lambda w, input: flags("--lattice", input.frictionless)
        + " " + flags("--lattice-frictional", input.frictional),
    shell:
        "granwave plot speeds {input.sweep} {params.lattices} -o {output} > {log} 2>&1"


rule figure_spectrum:
    input:
        lambda w: first_sample_path("modes", main_sample()[0]),
    output:
        f"{F}/spectrum.png",
    log:
        f"{R}/logs/figures/spectrum.log",
    shell:
        "granwave plot spectrum {input} -o {output} > {log} 2>&1"


rule eigensolve_vectors:
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
    input:
        modes=lambda w: first_sample_path("modes_vectors", main_sample()[0]),
        linear=lambda w: first_sample_path("linear", main_sample()[0]),
        packing=lambda w: first_sample_path("packing", main_sample()[0]),
    output:
        f"{F}/modes.png",
    log:
        f"{R}/logs/figures/modes.log",
    shell:
        "granwave plot modes {input.modes} {input.linear} {input.packing} -o {output} > {log} 2>&1"


rule snapshot_signal:
    input:
        f"{R}/linear/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    output:
        f"{R}/snapshots/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.h5",
    log:
        f"{R}/logs/snapshots/{{scene}}/p{{pressure}}/{{size}}/s{{seed}}.log",
    params:
        t_max=t_max,
        times=lambda w: ",".join(f"{t_max(w) * f / config['t_max_factor']:.6g}"
                                 for f in (0.25, 0.5, 0.75, 1.0)),
    resources:
        runtime=10,
    shell:
        "granwave propagate {input} --method time --ic {config[ic]} --t-max {params.t_max:.6g} "
        "--snapshots {params.times} -o {output} > {log} 2>&1"


rule figure_snapshot:
    input:
        signal=lambda w: first_sample_path("snapshots", main_sample()[0]),
        packing=lambda w: first_sample_path("packing", main_sample()[0]),
    output:
        f"{F}/snapshot.png",
    log:
        f"{R}/logs/figures/snapshot.log",
    shell:
        "granwave plot snapshot {input.signal} --packing {input.packing} -o {output} > {log} 2>&1"


rule figure_airy:
    output:
        f"{F}/airy.png",
    log:
        f"{R}/logs/figures/airy.log",
    shell:
        "granwave plot airy --n 100 --n 400 --n 1600 -o {output} > {log} 2>&1"


def sweep_paths():
    return [f"{R}/sweep/{scene}.json" for scene in scenes("disordered")]


def all_height_series():
    return [path for scene in scenes() for path in height_series_paths(scene)]


def all_summaries():
    return [path for scene in scenes() for path in sample_paths("summary", scene, ext="json")]


rule report:
    input:
        summaries=all_summaries(),
        heights=all_height_series(),
        sweeps=sweep_paths(),
        figures=figure_targets(),
        ensembles=[f"{R}/ensemble/{s}/p{p}/{sz}.json" for s in scenes("disordered")
                   for p in pressures(s) for sz in sizes(s, p)],
        spectra=[first_sample_path("spectrum", s, ext="json") for s in scenes("disordered")
                 if scene_spec(s).get("spectrum")],
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
                                        flags("--figures", input.figures)]),
    shell:
        "granwave report --config {params.config} {params.args} -o {output.md} > {log} 2>&1"


def damping_packing():
    d = config["damping"]
    return f"{R}/packing/{d['scene']}/p{fmt_p(d['pressure'])}/h{d['height']:g}/s0.h5"


rule damping_signal:
    input:
        lambda w: damping_packing(),
    output:
        f"{R}/damping/zeta{{zeta}}.h5",
    log:
        f"{R}/logs/damping/zeta{{zeta}}.log",
    params:
        t_max=lambda w: config["t_max_factor"] * crossing_time_of_damping(),
        amplitude=config["damping"]["amplitude"],
        samples=config["samples"],
    resources:
        runtime=60,
    shell:
        "granwave propagate {input} --method dem --ic {config[ic]} --damping {wildcards.zeta} "
        "--amplitude {params.amplitude} --t-max {params.t_max:.6g} --samples {params.samples} "
        "-o {output} > {log} 2>&1"


def crossing_time_of_damping():
    from granwave.workflow_support import crossing_time
    d = config["damping"]
    return crossing_time("disordered", scene_spec(d["scene"]), d["pressure"], f"h{d['height']:g}")


def damping_linear_reference():
    d = config["damping"]
    return f"{R}/signal/{d['scene']}/p{fmt_p(d['pressure'])}/h{d['height']:g}/s0.h5"


rule figure_damping:
    input:
        signals=[f"{R}/damping/zeta{z:g}.h5" for z in config["damping"]["zetas"]],
        reference=lambda w: damping_linear_reference(),
    output:
        f"{F}/damping.png",
    log:
        f"{R}/logs/figures/damping.log",
    shell:
        "granwave plot damping {input.signals} --reference {input.reference} -o {output} > {log} 2>&1"
