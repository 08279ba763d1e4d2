# Configuration: validation against the schema (with defaults), the sample
# lists of every scene, and the helpers that turn wildcards into CLI options.
import math

from snakemake.utils import min_version, validate

min_version("8.0")


configfile: "config/config.yaml"


validate(config, "../schemas/config.schema.yaml")

R = config["results"]


def fmt_p(p):
    """The pressure as it appears in paths (p1e-07, p0.0001, ...)."""
    return f"{float(p):g}"


def _disordered_entries(spec):
    """(pressure, height, seeds) triples of a disordered scene, series included."""
    out = {}
    for p in spec["pressures"]:
        for h in spec["heights"]:
            out[(fmt_p(p), f"h{h:g}")] = spec["seeds"]
    series = spec.get("series")
    if series:
        for p in series["pressures"]:
            for h in series["heights"]:
                key = (fmt_p(p), f"h{h:g}")
                out[key] = max(out.get(key, 0), series["seeds"])
    return out


def scene_kind(scene):
    for kind in ("disordered", "lattices", "chains"):
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
    return [(fmt_p(spec["pressure"]), f"n{n}", s) for n in spec["balls"] for s in range(spec["seeds"])]


def scenes(kind=None):
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
    return scene_spec(scene).get("solver", "modal")


def t_max(wildcards):
    """Record length: t_max_factor crossings at the perfect-lattice speed (SPEC §12), which is
    faster than the disordered front, so the first arrival is always inside the record."""
    from granwave.workflow_support import crossing_time
    kind = scene_kind(wildcards.scene)
    return config["t_max_factor"] * crossing_time(kind, scene_spec(wildcards.scene),
                                                  float(wildcards.pressure), wildcards.size)


wildcard_constraints:
    pressure=r"[0-9.e+-]+",
    size=r"[hrn][0-9.]+",
    seed=r"\d+",
    scene=r"[A-Za-z0-9_]+",
    zeta=r"[0-9.e+-]+",
