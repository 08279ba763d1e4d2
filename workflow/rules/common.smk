# Configuration: validation against the schema (with defaults), the sample
# lists of every scene, and the helpers that turn wildcards into CLI options.
import math
import os
import sys
from types import SimpleNamespace

from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version, validate

min_version("8.0")


# The quick default, unless config files are given on the command line: those replace it
# (snakemake would otherwise merge them into the default and keep its scenes).
if not workflow.overwrite_configfiles:

    configfile: os.path.join(workflow.basedir, "..", "config", "config.yaml")


def _stop(message):
    """End the workflow with one line naming the config key (no traceback)."""
    print(message, file=sys.stderr)
    sys.exit(2)


def _check_config():
    """The whole config, before any sample is listed: each config file read strictly (a key
    given twice, a binary or non-mapping file), no NaN or infinity, the schema, cross
    references, the labels that become paths, the number of samples and the results folder.
    Every failure is one line naming the key (granwave.workflow_config)."""
    import yaml
    from granwave import workflow_config as ws
    from granwave import workflow_record as wr

    for path in workflow.configfiles:
        message = ws.config_file_error(path)
        if message:
            _stop(message)
    message = ws.nonfinite_error(config)
    if message:
        _stop(message)
    with open(os.path.join(workflow.basedir, "schemas", "config.schema.yaml")) as f:
        message = ws.schema_error(config, yaml.safe_load(f))
    if message:
        _stop(message)
    validate(config, "../schemas/config.schema.yaml")  # fills in the defaults
    for check in (ws.cross_reference_error, ws.contact_error, ws.labels_error, ws.count_error, ws.shear_error,
                  wr.record_error, ws.width_error, ws.shocks_error):
        message = check(config)
        if message:
            _stop(message)
    message = ws.results_error(config["results"])
    if message:
        _stop(message)
    message = ws.device_error(config) if workflow.is_main_process else None
    if message:
        _stop(message)
    warning = wr.record_warning(config)
    if warning and workflow.is_main_process:
        print(warning, file=sys.stderr)


_check_config()

R = config["results"]


from granwave.workflow_config import WILDCARDS, height_label, pressure_label as fmt_p


def _disordered_entries(spec):
    """(pressure, height, seeds) triples of a disordered scene, series included."""
    out = {}
    for p in spec["pressures"]:
        for h in spec["heights"]:
            out[(fmt_p(p), height_label(h))] = spec["seeds"]
    series = spec.get("series")
    if series:
        for p in series["pressures"]:
            for h in series["heights"]:
                key = (fmt_p(p), height_label(h))
                out[key] = max(out.get(key, 0), series["seeds"])
    return out


def scene_kind(scene):
    for kind in ("disordered", "lattices", "chains", "continuum"):
        if scene in config[kind]:
            return kind
    raise ValueError(f"unknown scene {scene!r}")


def scene_spec(scene):
    return config[scene_kind(scene)][scene]


def samples(scene):
    """Every sample of a scene as (pressure, size, seed); size is h<height>, r<rows> or n<balls>."""
    kind, spec = scene_kind(scene), scene_spec(scene)
    if kind == "disordered":
        return [(p, size, s) for (p, size), n in sorted(_disordered_entries(spec).items())
                for s in range(n)]
    if kind == "lattices":
        return [(fmt_p(p), f"r{r}", 0) for p in spec["pressures"] for r in spec["rows"]]
    if kind == "continuum":
        return [(fmt_p(spec["pressure"]), height_label(h), s) for h in sorted(spec["heights"])
                for s in range(continuum_seeds(spec, h))]
    return [(fmt_p(spec["pressure"]), f"n{n}", s) for n in spec["balls"] for s in range(spec["seeds"])]


def continuum_seeds(spec, height):
    """Packings of a continuum scene at one height (more at the short heights: seeds_below)."""
    below = spec.get("seeds_below")
    if below and height <= below["height"]:
        return max(spec["seeds"], below["seeds"])
    return spec["seeds"]


def scenes(kind=None):
    """Scenes of one kind, or of the three kinds of the main study (continuum scenes have
    their own analyses and report section: scenes("continuum"))."""
    kinds = [kind] if kind else ["disordered", "lattices", "chains"]
    return [s for k in kinds for s in config[k]]


def sample_paths(stage, scene, ext="h5", pressure=None, size=None):
    """Paths of one stage's outputs for a scene (optionally one pressure / size)."""
    return [f"{R}/{stage}/{scene}/p{p}/{sz}/s{s}.{ext}" for p, sz, s in samples(scene)
            if (pressure is None or p == pressure) and (size is None or sz == size)]


def pressures(scene):
    return sorted({p for p, _, _ in samples(scene)}, key=float)


def sizes(scene, pressure):
    return sorted({sz for p, sz, _ in samples(scene) if p == pressure}, key=lambda s: float(s[1:]))


def grain_count(spec, height):
    """Grains for a nominal container height at the scene's width (2D: about one grain per d^2;
    3D: solid fraction ~0.62 of spheres of volume pi/6)."""
    w = spec["width"]
    if spec["dim"] == 2:
        return max(1, round(w * height))
    return max(1, round(w * w * height * 0.62 / (math.pi / 6)))


def ic_of(scene):
    spec = scene_spec(scene)
    return spec.get("ic", config["ic"])


def solver_of(scene):
    """The per-sample propagate rule's method (a lone sample asked for outside a batch)."""
    if scene_kind(scene) == "continuum":
        return "time"
    return "time" if scene_spec(scene).get("solver", "auto") == "time" else "modal"


def signal_method(scene):
    """How the batches compute a scene's signals (granwave.workflow_support.signal_of):
    modal, time or auto (the cheaper by predicted cost). Chains: modal, by the tridiagonal
    eigensolver (no dense n^3 cost); continuum columns: time domain."""
    if scene_kind(scene) == "chains":
        return "modal"
    if scene_kind(scene) == "continuum":
        return "time"
    return scene_spec(scene).get("solver", "auto")


def t_max(wildcards):
    """Record length: t_max_factor crossings (a continuum scene may set its own) at the perfect-lattice speed (docs/method.md §12), which is
    faster than the disordered front, so the first arrival is always inside the record."""
    from granwave.workflow_support import crossing_time
    kind = scene_kind(wildcards.scene)
    factor = scene_spec(wildcards.scene).get("t_max_factor", config["t_max_factor"])
    return factor * crossing_time(kind, scene_spec(wildcards.scene),
                                                  float(wildcards.pressure), wildcards.size)


wildcard_constraints:
    **WILDCARDS,


# ---- helpers of rules/packings.smk
# Samples: DEM packings (prepare-packing), perfect lattices and chains.


def prepare_args(wildcards):
    """prepare-packing options for one sample outside its batch: the options its batch would
    use (:func:`batch_sample`), so that a lone packing is made as in a batch."""
    make = batch_sample(wildcards.scene, wildcards.pressure, f"h{wildcards.height}",
                        int(wildcards.seed))["make"]
    return " ".join(f"--{key.replace('_', '-')} {value}" for key, value in make.items())


def contact_args(wildcards):
    """The scene's contact sub-models as CLI options (`--contact-law cone --cone-slope 0.1`): the
    lone lattice and chain rules' (a packing's are in prepare_args, from its batch's options)."""
    contact = scene_spec(wildcards.scene).get("contact") or {}
    return " ".join(f"--{key.replace('_', '-')} {value}" for key, value in contact.items())


def moduli_args(wildcards):
    """analyze moduli options for one sample outside its batch: local moduli where its batch
    computes them (not for continuum columns)."""
    sample = batch_sample(wildcards.scene, wildcards.pressure, wildcards.size, int(wildcards.seed))
    return "--local" if sample.get("local_moduli", True) else ""


# ---- threads and checkpoints of the DEM preparations (rules/packings.smk, rules/batches.smk)

#: A preparation of at least this many grains is tall: it writes a checkpoint under the results
#: folder (prepare-packing --checkpoint; every 600 s, so that a killed workflow goes on from it
#: with the same bits) and gets a thread per GRAINS_PER_THREAD grains. The quick default's
#: tallest column (25 x 80 d) has 2000 grains.
TALL_GRAINS = 4000
#: Grains per thread of a tall preparation (two threads run a 10 200-grain column twice as fast
#: as one: docs/dem.md "Performance").
GRAINS_PER_THREAD = 4000


def preparation_threads(grains):
    """Threads for a preparation of ``grains`` grains: 1 below TALL_GRAINS, else one per
    GRAINS_PER_THREAD grains, at most the cores the workflow was given (snakemake's --cores)."""
    if grains < TALL_GRAINS:
        return 1
    return int(max(1, min(given_cores(), grains // GRAINS_PER_THREAD)))


def given_cores():
    """Snakemake's --cores, or inf where none was given: `snakemake --unlock` and the like parse
    the workflow without it (and run no job), and snakemake raises on reading workflow.cores then."""
    try:
        cores = workflow.cores
    except WorkflowError:
        return math.inf
    return cores if isinstance(cores, int) and cores > 0 else math.inf


def batch_threads(samples):
    """Threads of a batch: those of its largest DEM preparation (the stages after it use them too)."""
    return preparation_threads(max((s["make"].get("grains", 0) for s in samples
                                    if s["kind"] in ("disordered", "continuum")), default=0))


def checkpoint_path(kind, make, tail):
    """The checkpoint file of a tall preparation (None for the others): under the results folder,
    outside every rule's outputs, so that snakemake keeps it when it removes a killed job's."""
    if kind in ("disordered", "continuum") and make["grains"] >= TALL_GRAINS:
        return f"{R}/checkpoints/{tail}.h5"
    return None


def packing_threads(wildcards):
    """Threads of rules/packings.smk's prepare_packing (a lone packing, outside its batch)."""
    sample = batch_sample(wildcards.scene, wildcards.pressure, f"h{wildcards.height}", int(wildcards.seed))
    return preparation_threads(sample["make"]["grains"])


def checkpoint_args(wildcards):
    """For a lone packing, tall: the shell's start making the checkpoint's folder and the
    --checkpoint option (its batch's checkpoint); ("", "") for the others."""
    sample = batch_sample(wildcards.scene, wildcards.pressure, f"h{wildcards.height}", int(wildcards.seed))
    path = sample.get("checkpoint")
    return (f"mkdir -p {os.path.dirname(path)} && ", f"--checkpoint {path}") if path else ("", "")


# ---- helpers of rules/batches.smk


def batch_sample(scene, p, size, seed):
    """What workflow/scripts/sample_batch.py needs for one sample (options and paths)."""
    kind, spec = scene_kind(scene), scene_spec(scene)
    tail = f"{scene}/p{p}/{size}/s{seed}"
    if kind in ("disordered", "continuum"):
        height = float(size[1:])
        make = dict(dim=spec["dim"], grains=grain_count(spec, height),
                    aspect=float(f"{height / spec['width']:.6g}"), pressure=float(p),
                    friction=float(spec["friction"]), poisson=float(spec["poisson"]),
                    polydispersity=float(spec["polydispersity"]), tol=float(spec["tol"]),
                    max_steps=int(spec["max_steps"]), seed=seed)
    elif kind == "lattices":
        make = dict(rows=int(size[1:]), width=int(spec["width"]), pressure=float(p),
                    friction=float(spec["friction"]), poisson=float(spec["poisson"]))
    else:
        make = dict(n_balls=int(size[1:]), pressure=float(p),
                    polydispersity=float(spec["polydispersity"]), seed=seed)
    make.update(spec.get("contact") or {})  # the scene's contact sub-models (granwave.contact_models)
    wc = SimpleNamespace(scene=scene, pressure=p, size=size, seed=seed)
    out = {stage: f"{R}/{stage}/{tail}.h5" for stage in ("packing", "linear", "signal")}
    for stage in summary_inputs(wc):  # front, and statics / moduli where the scene has them
        out[stage] = f"{R}/{stage}/{tail}.json"
    out["summary"] = f"{R}/summary/{tail}.json"
    sample = {"kind": kind, "scene": scene, "pressure": p, "size": size, "seed": seed, "make": make,
              "signal": {"method": signal_method(scene), "ic": ic_of(scene),
                         "t_max": float(f"{t_max(wc):.6g}"), "samples": config["samples"],
                         "safety": config["time_safety"]},
              "out": out}
    if kind in ("disordered", "continuum") and config["device"] == "gpu":
        sample["packing_given"] = True  # made with its height's seeds by gpu_packings (one GPU job)
    elif checkpoint_path(kind, make, tail):  # tall: resumes from its checkpoint (docs/dem.md)
        sample["checkpoint"] = checkpoint_path(kind, make, tail)
    if kind == "disordered" and not spec.get("local_moduli", True):
        sample["local_moduli"] = False
    if kind == "continuum":  # the scene's compaction rule (mean-flow unless it says otherwise)
        make["compaction"] = spec["compaction"]
    if kind == "continuum":  # time domain, the scene's own step and record, global moduli only
        sample["signal"].update(samples=spec.get("samples", config["samples"]),
                                safety=spec.get("time_safety", config["time_safety"]))
        sample["local_moduli"] = False
        sample["moduli_may_fail"] = True  # a floppy tall column loses its c_l, not its batch
    return sample


def gpu_packings():
    """device gpu: [(name, samples)], one per height of every disordered and continuum scene: the
    height's seeds, prepared together on one GPU by rules/gpu_packings.smk; [] on the CPU."""
    if config["device"] != "gpu":
        return []
    groups = {}
    for kind in ("disordered", "continuum"):
        for scene in scenes(kind):
            for p, size, seed in samples(scene):
                groups.setdefault((scene, p, size), []).append(batch_sample(scene, p, size, seed))
    return [(f"gpu_packings_{scene}_{k}", group)
            for k, ((scene, p, size), group) in enumerate(sorted(groups.items(), key=lambda g: g[0]))]


def gpu_packings_command(group):
    """The prepare-packing command of one height's seeds on the GPU (gpu_packings): the options of
    its samples (batch_sample's, without the seed), one file per seed at the samples' paths; a
    tall height (TALL_GRAINS) also one checkpoint per seed where checkpoint_path puts the CPU's,
    its folder made first, so that a killed GPU job goes on from them with the same bits."""
    first = group[0]
    make = {k: v for k, v in first["make"].items() if k != "seed"}
    options = " ".join(f"--{key.replace('_', '-')} {value}" for key, value in make.items())
    seeds = ",".join(str(s["seed"]) for s in group)
    folder = os.path.dirname(first["out"]["packing"])  # the samples' paths, s<seed>.h5
    pattern = os.path.join(folder, "s{seed}.h5")
    command = f"granwave prepare-packing {options} --seeds {seeds} --device gpu --quiet -o '{pattern}'"
    tail = f"{first['scene']}/p{first['pressure']}/{first['size']}/s{first['seed']}"
    path = checkpoint_path(first["kind"], first["make"], tail)
    if path is None:
        return command
    checkpoints = os.path.dirname(path)
    return f"mkdir -p {checkpoints} && {command} --checkpoint '{os.path.join(checkpoints, 's{seed}.h5')}'"


REFERENCE_KINDS = ("lattices", "chains")


def batches():
    """[(name, scene, samples)]: every disordered scene's samples in order, cut into batch_size
    pieces; the samples of all lattice and chain scenes together (no DEM preparation, each costs
    less than a process start-up), in reference_batch_size pieces named batch_reference_<k>
    (scene "reference"); the continuum scenes' in batches of equal predicted cost."""
    out = []
    for scene in scenes("disordered"):
        items = samples(scene)
        for k in range(0, len(items), config["batch_size"]):
            out.append((f"batch_{scene}_{k // config['batch_size']}", scene,
                        [batch_sample(scene, *s) for s in items[k:k + config["batch_size"]]]))
    reference = [batch_sample(scene, *s) for kind in REFERENCE_KINDS for scene in scenes(kind)
                 for s in samples(scene)]
    size = config["reference_batch_size"]
    for k in range(0, len(reference), size):
        out.append((f"batch_reference_{k // size}", "reference", reference[k:k + size]))
    for scene in scenes("continuum"):
        for k, part in enumerate(continuum_batches(samples(scene))):
            out.append((f"batch_{scene}_{k}", scene, [batch_sample(scene, *s) for s in part]))
    return out


def batch_priority(samples):
    """The batches with the most DEM work start first (snakemake otherwise starts ready jobs in
    no useful order, and a long batch started last is the run's tail): grains × height ×
    (1e-4 / p)^0.3, a preparation's cost roughly (the quick run's 2D packings take about twice
    the steps per decade of pressure below 1e-4), on a log scale from 0 to 50."""
    work = sum(s["make"].get("grains", 0) * float(s["size"][1:]) * (1e-4 / float(s["pressure"])) ** 0.3
               for s in samples if s["kind"] in ("disordered", "continuum"))
    if work == 0:
        return 60  # no DEM (lattices, chains): while the DEM kernels compile, before the pulse warm-up
    main = main_sample()
    if main and any((s["scene"], float(s["pressure"]), s["size"], int(s.get("seed", 0))) ==
                    (main[0], float(main[1]), main[2], 0) for s in samples):
        return 50  # the main sample's batch: its extras (spectrum, modes, damping pulses) wait for it
    # a continuum batch is followed by its scene's analysis (~12 CPU-s in the quick run): ahead
    # of disordered batches of the same work, or it ends the run (measured 2026-11-28)
    chain = 3 if any(s["kind"] == "continuum" for s in samples) else 0
    return int(min(49, max(0, 5 * math.log10(work) + chain))) if work > 0 else 0


def continuum_batches(items):
    """Samples of a continuum scene in batches of about equal cost: the tallest first, each to
    the batch with the least predicted DEM CPU so far (grains × steps ∝ H × H at fixed width
    under the mean-flow rule, the continuum scenes' default: docs/dem.md);
    as many batches as batch_size asks for."""
    n = max(1, math.ceil(len(items) / config["batch_size"]))
    parts, load = [[] for _ in range(n)], [0.0] * n
    for item in sorted(items, key=lambda s: (-float(s[1][1:]), s[2])):
        k = load.index(min(load))
        parts[k].append(item)
        load[k] += float(item[1][1:]) ** 2
    return [sorted(p, key=lambda s: (float(s[1][1:]), s[2])) for p in parts if p]


# ---- helpers of rules/linear.smk
def propagate_input(wildcards):
    """Modes for the modal sum; the linear system itself for time-domain scenes."""
    stage = "linear" if solver_of(wildcards.scene) == "time" else "modes"
    return f"{R}/{stage}/{wildcards.scene}/p{wildcards.pressure}/{wildcards.size}/s{wildcards.seed}.h5"


# ---- helpers of rules/analysis.smk
# Per-sample measurements, their one-file summaries, and the per-scene analyses:
# height series (c_tof, gamma, alpha), ensembles, spectra and the pressure sweep.


from granwave.workflow_support import STATICS_LAYER


def sample_height(scene, size):
    """Nominal container height of a sample (rows of a lattice are sqrt(3)/2 apart)."""
    value = float(size[1:])
    return value * math.sqrt(3.0) / 2.0 if size[0] == "r" else value


def summary_inputs(wildcards):
    kind = scene_kind(wildcards.scene)
    tail = f"{wildcards.scene}/p{wildcards.pressure}/{wildcards.size}/s{wildcards.seed}"
    inputs = {"front": f"{R}/front/{tail}.json"}
    if kind == "continuum":  # the packing's own global moduli give its c_l, c_t
        inputs["moduli"] = f"{R}/moduli/{tail}.json"
    elif kind in ("disordered", "lattices"):
        # Bulk statics exclude 3 d at each wall (docs/method.md §4): only containers with a bulk have them.
        if sample_height(wildcards.scene, wildcards.size) > 2 * STATICS_LAYER + 1:
            inputs["statics"] = f"{R}/statics/{tail}.json"
        if scene_spec(wildcards.scene).get("moduli", True):
            inputs["moduli"] = f"{R}/moduli/{tail}.json"
    return inputs


def height_signals(wildcards):
    return sample_paths("signal", wildcards.scene, pressure=wildcards.pressure)


def scene_analyses():
    """[(name, scene, commands)]: the light analyses of each scene (of all lattice and chain
    scenes together: analyses_reference, scene "reference"), run in one job by
    workflow/scripts/analysis_batch.py (granwave.workflow_support.run_command): a height series
    per pressure with two sizes or more (`granwave analyze heights`, as rule heights runs it)
    and, for disordered scenes, an ensemble per pressure and size (`granwave analyze ensemble`,
    as rule ensemble runs it) and the pressure sweep (as rule pressure_sweep runs it). Each
    command: its arguments, the input files made by other jobs, its output files (``tables``
    a folder) and the file that gets what it prints."""
    edges = ",".join(f"{h:g}" for h in config["edge_heights"])
    out, reference = [], []
    for scene in scenes():
        commands = []
        for p in pressures(scene):
            if len(sizes(scene, p)) < 2:
                continue
            signals = sample_paths("signal", scene, pressure=p)
            path = f"{R}/heights/{scene}/p{p}.json"
            commands.append({"scene": scene, "pressure": p, "size": "all", "stage": "heights",
                             "args": ["analyze", "heights", *signals, "--edge-heights", edges, "--json"],
                             "in": signals, "out": {"result": path}, "printed": path})
        for p in pressures(scene) if scene_kind(scene) == "disordered" else []:
            for size in sizes(scene, p):
                signals = sample_paths("signal", scene, pressure=p, size=size)
                h5, path = f"{R}/ensemble/{scene}/p{p}/{size}.h5", f"{R}/ensemble/{scene}/p{p}/{size}.json"
                commands.append({"scene": scene, "pressure": p, "size": size, "stage": "ensemble",
                                 "args": ["analyze", "ensemble", *signals, "-o", h5, "--json"],
                                 "in": signals, "out": {"result": path, "h5": h5}, "printed": path})
        if scene_kind(scene) == "disordered":  # the sweep reads the height series made above
            summaries = sample_paths("summary", scene, ext="json")
            h5, path = f"{R}/sweep/{scene}.h5", f"{R}/sweep/{scene}.json"
            commands.append({"scene": scene, "pressure": "all", "size": "all", "stage": "sweep",
                             "args": ["pressure-sweep", *summaries, *height_series_paths(scene),
                                      "-o", h5, "--tables", f"{R}/sweep/{scene}_tables", "--json"],
                             "in": summaries, "printed": path,
                             "out": {"result": path, "h5": h5, "tables": f"{R}/sweep/{scene}_tables"}})
        if commands and scene_kind(scene) in REFERENCE_KINDS:
            reference += commands  # the lattices' and chains' height series: one job for all
        elif commands:
            out.append((f"analyses_{scene}", scene, commands))
    if reference:
        out.append(("analyses_reference", "reference", reference))
    return out


def sweep_inputs(wildcards):
    inputs = {"summaries": sample_paths("summary", wildcards.scene, ext="json")}
    inputs["heights"] = [f"{R}/heights/{wildcards.scene}/p{p}.json"
                         for p in pressures(wildcards.scene) if len(sizes(wildcards.scene, p)) >= 2]
    return inputs


# ---- helpers of rules/report.smk
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


def lattice_flags(input):
    return " ".join([flags("--lattice", input.frictionless),
                     flags("--lattice-frictional", input.frictional)])


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
    if any(height_series_paths(s) for s in scenes("disordered")):
        figs.append(f"{F}/exponents.png")
    if any(height_series_paths(s) for s in scenes("chains")):  # L 100-1600: apart from L 5-26
        figs.append(f"{F}/exponents_chains.png")
    if config["damping"]["enabled"]:
        figs.append(f"{F}/damping.png")
    figs += [f"{F}/continuum_{s}.png" for s in scenes("continuum")]
    figs += [f"{F}/shear_{s}.png" for s in shear_scenes()]
    figs += [f"{F}/shocks_{s}.png" for s in shocks_scenes()]
    return figs


def study_figures():
    """[(name, commands)]: the figures of the main study (airy, network, roses, signals,
    coherent, compare, arrivals, exponents, speeds: those of figure_targets() that its rules
    figure_airy ... figure_speeds make), run in one job by workflow/scripts/analysis_batch.py
    with the options those rules give them. Each command: its arguments, input files and figure."""
    commands = []

    def plot(kind, args, inputs):
        path = f"{F}/{kind}.png"
        commands.append({"scene": "figures", "pressure": "all", "size": kind, "stage": "figure",
                         "args": ["plot", *args, "-o", path], "in": inputs, "out": {"result": path}})

    plot("airy", ["airy", "--n", "100", "--n", "400", "--n", "1600", "--scene", "exact chain"], [])
    if main_sample():
        scene, p, size = main_sample()
        named = ["--scene", scene]  # every figure's title names its scene
        packing = first_sample_path("packing", scene)
        for kind in ("network", "roses"):
            plot(kind, [kind, packing, *named], [packing])
        signals = sample_paths("signal", scene, pressure=p, size=size)
        ensemble = f"{R}/ensemble/{scene}/p{p}/{size}.h5"
        plot("signals", ["signals", *signals, "--ensemble", ensemble, *named], [*signals, ensemble])
        ensembles = [f"{R}/ensemble/{scene}/p{p}/{sz}.h5" for sz in sizes(scene, p)]
        plot("coherent", ["coherent", *ensembles, *named], ensembles)
        firsts = [first_sample_path("signal", s) for s in scenes("disordered")]
        plot("compare", ["compare", *firsts, *flags("--label", scenes("disordered")).split(),
                         "--scene", " vs ".join(scenes("disordered"))], firsts)
        if len(sizes(scene, p)) >= 2:
            heights = f"{R}/heights/{scene}/p{p}.json"
            plot("arrivals", ["arrivals", heights, *named], [heights])
        if len(pressures(scene)) >= 2:
            sweep = f"{R}/sweep/{scene}.json"
            lattices = [lattice_heights(False), lattice_heights(True)]
            plot("speeds", ["speeds", sweep, *flags("--lattice", lattices[0]).split(),
                            *flags("--lattice-frictional", lattices[1]).split(), *named],
                 [sweep, *lattices[0], *lattices[1]])
    for kind, series in (("exponents", [s for s in exponent_series() if scene_kind(s[0]) != "chains"]),
                         ("exponents_chains", [s for s in exponent_series() if scene_kind(s[0]) == "chains"])):
        if series:
            paths = [path for _, path in series]
            plot(kind, ["exponents", *paths, *flags("--label", [scene for scene, _ in series]).split()], paths)
    return [("figures_study", commands)]


def main_sample_extras():
    """[(name, commands)]: what the report takes from single samples beyond their batches, in one
    job (one process: each `granwave` command alone costs ~1.5-3 CPU-s of start-up, more than
    most of these): the spectrum of each scene that asks for one (eigensolve, analyze spectrum)
    and, for the main sample, its mode shapes (eigensolve --vectors), the snapshot signal, the
    DEM damping pulses and their table, and the figures spectrum, modes, snapshot and damping.
    Each command has the options of the per-file rule that makes its file alone (rules eigensolve,
    spectrum, eigensolve_vectors, snapshot_signal, damping_signal, damping_table, figure_*)."""
    commands = []

    def command(stage, args, inputs, result, printed=False):
        commands.append({"scene": "extras", "pressure": "all", "size": os.path.basename(result),
                         "stage": stage, "args": args, "in": inputs, "out": {"result": result},
                         **({"printed": result} if printed else {})})

    for scene in scenes("disordered"):
        if scene_spec(scene).get("spectrum"):
            linear, modes = first_sample_path("linear", scene), first_sample_path("modes", scene)
            spectrum = first_sample_path("spectrum", scene, ext="json")
            command("eigensolve", ["eigensolve", "--threads", "1", linear, "-o", modes], [linear], modes)
            command("spectrum", ["analyze", "spectrum", modes, "--json"], [], spectrum, printed=True)
    if main_sample():
        scene, p, size = main_sample()
        packing, linear = first_sample_path("packing", scene), first_sample_path("linear", scene)
        vectors, snapshots = first_sample_path("modes_vectors", scene), first_sample_path("snapshots", scene)
        if scene_spec(scene).get("spectrum"):
            modes = first_sample_path("modes", scene)
            command("figure", ["plot", "spectrum", modes, "--scene", scene, "-o", f"{F}/spectrum.png"], [],
                    f"{F}/spectrum.png")
        command("eigensolve", ["eigensolve", linear, "--vectors", "-o", vectors], [linear], vectors)
        command("figure", ["plot", "modes", vectors, linear, packing, "--scene", scene, "-o", f"{F}/modes.png"],
                [packing], f"{F}/modes.png")
        wc = SimpleNamespace(scene=scene, pressure=p, size=size, seed=0)
        command("snapshot", ["propagate", linear, "--method", "time", "--ic", config["ic"],
                             "--t-max", f"{t_max(wc):.6g}", "--snapshots",
                             ",".join(f"{t:.6g}" for t in snapshot_times(wc)), "-o", snapshots], [], snapshots)
        command("figure", ["plot", "snapshot", snapshots, "--packing", packing, "--modes", vectors,
                           "--linear", linear, "--scene", scene, "-o", f"{F}/snapshot.png"], [], f"{F}/snapshot.png")
    if config["damping"]["enabled"]:
        d, packing = config["damping"], damping_packing()
        signals = [f"{R}/damping/zeta{z:g}.h5" for z in d["zetas"]]
        for z, path in zip(d["zetas"], signals):
            command("damping", ["propagate", packing, "--method", "dem", "--ic", config["ic"],
                                "--damping", f"{z:g}", "--amplitude", str(d["amplitude"]),
                                "--t-max", f"{damping_t_max():.6g}", "--samples", str(config["samples"]),
                                "-o", path], [packing, kernels_marker("pulse")], path)
        command("damping_table", ["analyze", "damping", *signals, "--json"], [], f"{R}/damping/table.json",
                printed=True)
        reference = damping_linear_reference()
        command("figure", ["plot", "damping", *signals, "--reference", reference, "--scene", d["scene"],
                           "-o", f"{F}/damping.png"], [reference], f"{F}/damping.png")
    return [("sample_extras", commands)] if commands else []


def continuum_jobs():
    """[(name, commands)]: per continuum scene, its front against distance, its attenuation and
    its figure in one job (one process), with the options of rules continuum_front,
    continuum_attenuation and figure_continuum."""
    out = []
    for scene in scenes("continuum"):
        signals = sample_paths("signal", scene)
        moduli = sample_paths("moduli", scene, ext="json")
        front, attenuation = f"{R}/continuum/{scene}/front.json", f"{R}/continuum/{scene}/attenuation.json"
        figure = f"{F}/continuum_{scene}.png"

        def command(stage, args, inputs, result, printed):
            return {"scene": scene, "pressure": "all", "size": "all", "stage": stage, "args": args,
                    "in": inputs, "out": {"result": result}, **({"printed": result} if printed else {})}

        out.append((f"continuum_{scene}", [
            command("continuum", ["analyze", "continuum", *signals, *flags("--moduli", moduli).split(),
                                  "--json"], [*signals, *moduli], front, True),
            command("attenuation", ["analyze", "attenuation", *signals, "--bootstrap",
                                    str(scene_spec(scene)["bootstrap"]), *flags("--moduli", moduli).split(),
                                    "--lateral-period", str(scene_spec(scene)["width"]), "--json"],
                    [*signals, *moduli], attenuation, True),
            command("figure", ["plot", "continuum", front, "--attenuation", attenuation, "--scene", scene,
                               "-o", figure], [], figure, False)]))
    return out


def report_inputs():
    inputs = [f"{R}/report/index.md"]
    return inputs


def all_timings():
    """The timing tables (`timings` outputs) of every batch, analysis and figure job: the run's
    CPU time on the report's first page."""
    tables = [f"{R}/timings/{name}.tsv" for name, _, _ in batches()]
    tables += [f"{R}/timings/analyses/{name}.tsv" for name, _, _ in scene_analyses()]
    tables += [f"{R}/timings/analyses/{name}.tsv"
               for name, _ in study_figures() + main_sample_extras() + continuum_jobs()]
    tables += [f"{R}/timings/shear/{name}.tsv" for name, _, _ in shear_batches()]
    tables += [f"{R}/timings/shocks/{name}.tsv" for name, _, _ in shocks_batches()]
    return tables


def continuum_outputs():
    """The continuum analyses of every continuum scene (front and attenuation JSON)."""
    return [f"{R}/continuum/{s}/{what}.json" for s in scenes("continuum")
            for what in ("front", "attenuation")]


def exponent_series():
    series = []
    for scene in scenes("disordered"):
        series += [(scene, path) for path in height_series_paths(scene)[-1:]]
    for scene in scenes("chains"):
        series += [(scene, path) for path in height_series_paths(scene)]
    return series


def lattice_heights(frictional):
    return [path for scene in scenes("lattices")
            if (scene_spec(scene)["friction"] > 0) == frictional
            for path in height_series_paths(scene)]


def sweep_paths():
    return [f"{R}/sweep/{scene}.json" for scene in scenes("disordered")]


def all_height_series():
    return [path for scene in scenes() for path in height_series_paths(scene)]


def all_summaries():
    return [path for scene in scenes() for path in sample_paths("summary", scene, ext="json")]


def damping_packing():
    d = config["damping"]
    return f"{R}/packing/{d['scene']}/p{fmt_p(d['pressure'])}/{height_label(d['height'])}/s0.h5"


def crossing_time_of_damping():
    from granwave.workflow_support import crossing_time
    d = config["damping"]
    return crossing_time("disordered", scene_spec(d["scene"]), d["pressure"], height_label(d["height"]))


def damping_t_max():
    """Record length of the DEM damping pulses: t_max_factor crossings of the damped sample."""
    return config["t_max_factor"] * crossing_time_of_damping()


def snapshot_times(wildcards):
    """Times of the snapshot signal's displacement fields: 1/4 ... 1 of the crossing time."""
    return [float(f"{t_max(wildcards) * f / config['t_max_factor']:.6g}") for f in (0.25, 0.5, 0.75, 1.0)]


def damping_linear_reference():
    d = config["damping"]
    return f"{R}/signal/{d['scene']}/p{fmt_p(d['pressure'])}/{height_label(d['height'])}/s0.h5"


# ---- helpers of rules/shear.smk
# The shear scenes kick packings of a frictional disordered scene (its linear systems and moduli).


def shear_scenes():
    return list(config.get("shear") or {})


def shear_samples(scene):
    """(pressure, size, seed) of the source scene's samples a shear scene uses."""
    spec = config["shear"][scene]
    ps = {fmt_p(p) for p in spec["pressures"]} if spec.get("pressures") else None
    hs = {height_label(h) for h in spec["heights"]} if spec.get("heights") else None
    n = spec.get("seeds")
    return [(p, sz, s) for p, sz, s in samples(spec["scene"])
            if (ps is None or p in ps) and (hs is None or sz in hs) and (n is None or s < n)]


def shear_sample(scene, p, size, seed):
    """What workflow/scripts/shear_batch.py needs for one packing (options and paths)."""
    spec = config["shear"][scene]
    src, tail = spec["scene"], f"p{p}/{size}/s{seed}"
    return {"scene": scene, "source_scene": src, "pressure": p, "size": size, "seed": seed,
            "wavelengths": [float(w) for w in spec["wavelengths"]], "pulse": spec["pulse"],
            "method": spec["method"], "safety": spec["time_safety"], "samples": spec["samples"],
            "record": spec["record"],
            "in": {"linear": f"{R}/linear/{src}/{tail}.h5", "moduli": f"{R}/moduli/{src}/{tail}.json"},
            "out": {"shear_signal": f"{R}/shear_signal/{scene}/{tail}.h5",
                    "normal_signal": f"{R}/shear_pwave/{scene}/{tail}.h5",
                    "picks": f"{R}/shear/{scene}/{tail}.json"}}


def shear_batches():
    """[(name, scene, samples)] of every shear scene, cut into its batch_size pieces."""
    out = []
    for scene in shear_scenes():
        items, n = shear_samples(scene), config["shear"][scene]["batch_size"]
        for k in range(0, len(items), n):
            out.append((f"shear_batch_{scene}_{k // n}", scene,
                        [shear_sample(scene, *s) for s in items[k:k + n]]))
    return out


def shear_picks(scene):
    return [shear_sample(scene, *s)["out"]["picks"] for s in shear_samples(scene)]


def shear_outputs():
    return [f"{R}/shear/{s}/analysis.json" for s in shear_scenes()]


# ---- helpers of rules/shocks.smk (included only when the config has a shocks section)
# A shocks scene makes its own packings (2D, or 3D) and pushes each at every drive (docs/shocks.md).


def shocks_scenes():
    return list(config.get("shocks") or {})


def shocks_sample(scene, p, seed):
    """What workflow/scripts/shocks_batch.py needs for one packing (options and paths)."""
    spec = config["shocks"][scene]
    height, width = float(spec["height"]), int(spec["width"])
    size = height_label(height)
    make = dict(dim=int(spec["dim"]), grains=grain_count(spec, height), aspect=float(f"{height / width:.6g}"),
                pressure=float(p), friction=float(spec["friction"]), poisson=float(spec["poisson"]),
                polydispersity=float(spec["polydispersity"]), tol=float(spec["tol"]),
                max_steps=int(spec["max_steps"]), seed=seed, **(spec.get("contact") or {}))
    tail = f"{scene}/p{p}/{size}/s{seed}"
    return {"scene": scene, "pressure": p, "size": size, "seed": seed, "make": make,
            "drives": [float(d) for d in spec["drives"]], "max_strain": float(spec["max_strain"]),
            "damping": float(spec["damping"]), "samples": int(spec["samples"]), "bin": float(spec["bin"]),
            "out": {"packing": f"{R}/shocks_packing/{tail}.h5", "record": f"{R}/shocks/{tail}.json"}}


def shocks_samples(scene):
    spec = config["shocks"][scene]
    return [(fmt_p(p), s) for p in spec["pressures"] for s in range(spec["seeds"])]


def shocks_batches():
    """[(name, scene, samples)] of every shocks scene, cut into its batch_size pieces."""
    out = []
    for scene in shocks_scenes():
        items, n = shocks_samples(scene), config["shocks"][scene]["batch_size"]
        for k in range(0, len(items), n):
            out.append((f"shocks_batch_{scene}_{k // n}", scene,
                        [shocks_sample(scene, *s) for s in items[k:k + n]]))
    return out


def shocks_records(scene):
    return [shocks_sample(scene, *s)["out"]["record"] for s in shocks_samples(scene)]


def shocks_outputs():
    return [f"{R}/shocks/{s}/analysis.json" for s in shocks_scenes()]


def _check_samples():
    """Every job's options through its stage's own parameter checks (granwave/params.py), as the
    jobs will pass them: each sample of each batch, the height series, the continuum analyses,
    the damping pulses and the snapshot signal (one line naming the config key, exit 2)."""
    from granwave.workflow_config import analyses_error, samples_error

    message = samples_error(batches(), config)
    if message is None:
        snapshot = None
        if main_sample():
            scene, p, size = main_sample()
            wc = SimpleNamespace(scene=scene, pressure=p, size=size, seed=0)
            snapshot = (float(f"{t_max(wc):.6g}"), snapshot_times(wc))
        message = analyses_error(
            config, snapshot=snapshot,
            damping_t_max=float(f"{damping_t_max():.6g}") if config["damping"]["enabled"] else None)
    for scene in shear_scenes() if message is None else []:
        if not shear_samples(scene):
            message = (f"config: shear.{scene}: selects no packing of disordered."
                       f"{config['shear'][scene]['scene']} (pressures, heights and seeds together)")
            break
    if message:
        _stop(message)


_check_samples()


# ---- helpers of rules/compile.smk (the kernel warm-ups)
def warm_up_samples():
    """One sample per scene, its cheapest to make (fewest grains, then highest pressure):
    the warm-ups run these, the lattices and chains shrunk further."""
    best = {}
    for _name, _scene, samples in batches():
        for s in samples:
            scene = s["scene"]  # the reference batches hold several scenes
            key = (s["make"].get("grains", s["make"].get("n_balls", s["make"].get("rows", 0))),
                   -float(s["pressure"]))
            if scene not in best or key < best[scene][0]:
                best[scene] = (key, s)
    return [s for _key, s in best.values()]


def pulse_warm_up_on_lattice():
    """Whether the DEM pulse's warm-up runs on a lattice, without the "dem" warm-up before it."""
    if not config["damping"]["enabled"]:
        return True  # nothing to warm up
    from granwave.workflow_support import pulse_on_lattice

    made = [s["make"] for s in warm_up_samples() if s["scene"] == config["damping"]["scene"]]
    return not made or pulse_on_lattice(made[0])


def unrecorded(value):
    """``value`` as a params value that snakemake leaves out of its params trigger (it records
    only builtin types). The warm-ups' samples follow the config's scenes: recorded, a config
    that adds a scene or a height to an existing results folder reran the warm-up, and snakemake
    9 then scheduled the warm-up alone, none of the new samples, until a second invocation
    (tests/test_workflow.py, test_tiny_workflow_end_to_end). The jobs read ``.value``."""
    return SimpleNamespace(value=value)


def kernels_marker(family):
    return ancient(f"{R}/kernels/{family}.json")


def kernels_of(scene):
    """The warm-up markers a scene's batches wait for (a shear scene: the time domain's)."""
    if scene in shear_scenes() or scene == "reference":  # reference: the lattice and chain batches
        return [kernels_marker("linear")]
    if scene_kind(scene) in ("disordered", "continuum"):
        return [kernels_marker("dem"), kernels_marker("linear")]
    return [kernels_marker("linear")]
