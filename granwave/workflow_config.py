"""Checks of a workflow config, each returning one line naming the offending key (or None).

The Snakefile runs them before it lists any sample (workflow/rules/common.smk): each config
file read strictly, no NaN or infinity, the schema, cross references between scenes, the labels
that become paths, the number of samples, the results folder, the analyses' and the shear
scenes' options; and the closed forms the checks and the job graph need.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

SCENE_KINDS = ("disordered", "lattices", "chains", "continuum")


def _key(path) -> str:
    """A config key path as written in YAML terms: damping.scene, disordered.x.heights[1]."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def schema_error(config: dict, schema: dict) -> str | None:
    """The first schema violation of ``config`` as one line naming its key, or None.

    Checked before Snakemake's own validation (which fills in the defaults), whose
    message quotes the whole schema; stricter than it in one point: an integer must be
    written as one (2, not 2.0).
    """
    import jsonschema

    # An integer is an int: JSON schema takes 2.0 for one, and range(2.0) fails while the
    # workflow lists its samples.
    checker = jsonschema.Draft202012Validator.TYPE_CHECKER.redefine(
        "integer", lambda _checker, value: isinstance(value, int) and not isinstance(value, bool))
    strict = jsonschema.validators.extend(jsonschema.Draft202012Validator, type_checker=checker)
    validator = strict(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(config))
    if error is None:
        return None
    if error.validator == "additionalProperties":
        known = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(known))
        key = _key([*error.absolute_path, extra[0]]) if extra else _key(error.absolute_path)
        hint = f" (known keys: {', '.join(known)})" if known else ""
        return f"config: unknown key {key}{hint}"
    if "propertyNames" in error.absolute_schema_path:
        return (f"config: {_key([*error.absolute_path, error.instance])}: a scene name must start "
                "with a letter and hold only letters, digits and _ (it becomes part of paths and "
                "job names)")
    return f"config: {_key(error.absolute_path)}: {error.message}"


def _index_of(values, label, text):
    """The index of the first value whose path label is ``text`` (None if none)."""
    for i, value in enumerate(values or []):
        if label(value) == text:
            return i
    return None


def sample_keys(config: dict, kind: str, scene: str, sample: dict) -> dict:
    """Config key of each option of one workflow sample (its ``make`` and ``signal`` fields,
    as :func:`samples_error` passes them to the stages' Params), for the one-line refusal."""
    base = f"{kind}.{scene}"
    spec = (config.get(kind) or {}).get(scene) or {}
    size = sample["size"]
    keys = {"compaction": f"{base}.compaction", "seed": f"{base}.seeds"}
    for field in ("dim", "friction", "poisson", "polydispersity", "tol", "max_steps", "width"):
        keys[field] = f"{base}.{field}"
    if kind in ("disordered", "lattices"):
        for sub in ("", "series."):
            part = spec.get("series") if sub else spec
            i = _index_of((part or {}).get("pressures"), pressure_label, sample["pressure"])
            if i is not None:
                keys["pressure"] = f"{base}.{sub}pressures[{i}]"
                break
    else:
        keys["pressure"] = f"{base}.pressure"
    if kind in ("disordered", "continuum"):
        key = f"{base}.heights"
        i = _index_of(spec.get("heights"), height_label, size)
        if i is None and spec.get("series"):
            key = f"{base}.series.heights"
            i = _index_of(spec["series"]["heights"], height_label, size)
        where = f"{key}[{i}]" if i is not None else key
        keys["grains"] = keys["aspect"] = f"{where} (with {base}.width)"
    elif kind == "lattices":
        keys["rows"] = f"{base}.rows[{_index_of(spec.get('rows'), lambda r: f'r{r}', size)}]"
    else:
        keys["balls"] = f"{base}.balls[{_index_of(spec.get('balls'), lambda n: f'n{n}', size)}]"
    for field in contact_keys(kind):
        keys[field] = f"{base}.contact.{field}"
    own = kind == "continuum"  # a continuum scene may set its own record, step and length
    keys["method"] = f"{base}.solver"
    keys["ic"] = f"{base}.ic" if kind == "chains" else "ic"
    keys["t_max"] = f"{base}.t_max_factor" if own and "t_max_factor" in spec else "t_max_factor"
    keys["samples"] = f"{base}.samples" if own and "samples" in spec else "samples"
    keys["safety"] = f"{base}.time_safety" if own and "time_safety" in spec else "time_safety"
    return keys


def samples_error(batches, config: dict | None = None) -> str | None:
    """The first sample of ``batches`` (``[(name, scene, samples)]``, as the workflow builds them)
    whose options its stage would refuse, as one line naming the config key (given ``config``)
    and the sample; None if all pass. The workflow calls this at parse time, so that a value
    the CLI refuses (a pressure out of range, a seed too large, ...) stops a dry run instead of
    a job hours later."""
    from .params import ChainParams, LatticeParams, PrepareParams, PropagateParams

    makers = {"disordered": PrepareParams, "continuum": PrepareParams, "lattices": LatticeParams,
              "chains": ChainParams}
    for _name, batch_scene, items in batches:
        for sample in items:
            scene = sample.get("scene", batch_scene)  # a batch may hold several scenes (lattices, chains)
            tail = f"{scene}/p{sample['pressure']}/{sample['size']}/s{sample['seed']}"
            make = dict(sample["make"])
            if sample["kind"] == "chains":
                make["balls"] = make.pop("n_balls")
            sig = sample["signal"]
            signal = dict(method=sig["method"], ic=sig["ic"], t_max=sig["t_max"],
                          samples=sig["samples"], safety=sig["safety"])
            for cls, values in ((makers[sample["kind"]], make), (PropagateParams, signal)):
                if config is None:  # no config to name keys from: name the sample
                    text = refusal(cls, values)
                    if text:
                        return f"config: {scene}, sample {tail[len(scene) + 2:]}: {text}"
                    continue
                message = params_error(cls, values, sample_keys(config, sample["kind"], scene, sample),
                                       f" (sample {tail})")
                if message:
                    return message
    return None


#: the contact sub-models' kinds each scene kind may set in its ``contact`` mapping (a lattice has
#: no dashpot or history, a chain only a normal law per contact; granwave.contact_models)
CONTACT_KINDS = {"disordered": None, "continuum": None, "lattices": ("normal", "tangential"), "chains": ("normal",)}


def contact_keys(kind: str) -> tuple:
    """The keys a scene of ``kind`` may give in its ``contact`` mapping: the options of its contact
    kinds and their sub-models' parameters (the kinds' own, friction and poisson, are scene keys)."""
    from .contact_models import options as CO

    kinds = CONTACT_KINDS[kind] or tuple(CO.KINDS)
    return tuple(CO.KINDS[k]["option"] for k in kinds) + tuple(n for n, p in CO.PARAMETERS.items()
                                                               if p["kind"] in kinds)


def contact_error(config: dict) -> str | None:
    """The first scene whose ``contact`` mapping (the contact sub-models of its packings, by the
    names of prepare-packing's options; granwave.contact_models) names an unknown key, a sub-model
    not registered or a parameter out of range, as one line naming the key; None if all pass."""
    from .contact_models import options as CO

    for kind in SCENE_KINDS:
        for scene, spec in (config.get(kind) or {}).items():
            contact = (spec or {}).get("contact") or {}
            base = f"{kind}.{scene}.contact"
            allowed = contact_keys(kind)
            for key, value in contact.items():
                if key not in allowed:
                    return f"config: unknown key {base}.{key} (known keys: {', '.join(allowed)})"
                options = {k["option"] for k in CO.KINDS.values()}
                if (key in options) != isinstance(value, str) or isinstance(value, bool):
                    what = "a sub-model's name" if key in options else "a number"
                    return f"config: {base}.{key}: must be {what}, got {value!r}"
            values = {**CO.values_of(dict(contact)), "friction": float(spec.get("friction", 0.0)),
                      "poisson": float(spec.get("poisson", 0.0))}
            try:
                CO.check(values, friction=values["friction"] if kind != "chains" else None)
            except ValueError as e:
                text = str(e)
                first = text.split(" ", 1)[0]
                key = next((k for k in contact if k == first), None)
                if key is None:  # "unknown contact law 'x'", "... needs friction > 0": the option's key
                    key = next((k for k in contact if isinstance(contact[k], str) and repr(contact[k]) in text),
                               next(iter(contact), ""))
                return f"config: {base}.{key}: {text}"
    return None


def cross_reference_error(config: dict) -> str | None:
    """The first inconsistency between keys of a (schema-valid, defaulted) config, or None.

    Checks: a scene name is used once over disordered / lattices / chains; a height
    series sits at pressures of its scene; the damping series names a disordered scene
    and one of its samples (its linear reference signal is that sample's); edge
    heights are two different heights.
    """
    owner = {}
    for kind in SCENE_KINDS:
        for scene in config.get(kind) or {}:
            if scene in owner:
                return f"config: scene {scene!r} is defined twice ({owner[scene]}.{scene} and {kind}.{scene})"
            owner[scene] = kind
    for scene, spec in (config.get("disordered") or {}).items():
        series = spec.get("series")
        if series:
            for i, p in enumerate(series["pressures"]):
                if p not in spec["pressures"]:
                    return (f"config: disordered.{scene}.series.pressures[{i}] = {p:g} is not one of "
                            f"disordered.{scene}.pressures ({', '.join(f'{q:g}' for q in spec['pressures'])})")
    damping = config.get("damping") or {}
    if damping.get("enabled"):
        scene = damping["scene"]
        if owner.get(scene) != "disordered":
            have = ", ".join(config.get("disordered") or {}) or "none"
            where = f" (it is a {owner[scene]} scene)" if scene in owner else ""
            return (f"config: damping.scene = {scene!r} is not a disordered scene{where}; "
                    f"disordered scenes: {have}")
        spec = config["disordered"][scene]
        series = spec.get("series") or {"pressures": [], "heights": []}
        if damping["pressure"] not in spec["pressures"]:
            return (f"config: damping.pressure = {damping['pressure']:g} is not one of "
                    f"disordered.{scene}.pressures ({', '.join(f'{q:g}' for q in spec['pressures'])})")
        heights = list(spec["heights"])
        if damping["pressure"] in series["pressures"]:
            heights += series["heights"]
        if damping["height"] not in heights:
            return (f"config: damping.height = {damping['height']:g} is not a height of "
                    f"disordered.{scene} at pressure {damping['pressure']:g} "
                    f"({', '.join(f'{h:g}' for h in sorted(set(heights)))})")
    edges = config.get("edge_heights")
    if edges and not edges[0] < edges[1]:
        return f"config: edge_heights = {list(edges)} must be two heights, lower first"
    return None


# ------------------------------------------------------------------ the dry run's config checks
# Everything a job would refuse is refused while Snakemake parses the workflow (common.smk):
# the config files themselves, the schema, cross references, the labels that become paths,
# the results folder, and every job's parameters through its stage's own Params class
# (granwave/params.py: the one home of every range).

#: Wildcard constraints of the workflow (common.smk applies them; labels are checked against them).
WILDCARDS = {"pressure": r"[0-9.e+-]+", "size": r"[hrn][0-9.]+", "seed": r"\d+",
             "scene": r"[A-Za-z0-9_]+", "zeta": r"[0-9.e+-]+"}

#: Most samples one workflow config may hold. Every sample's files are named in the job graph
#: at parse time; the paper config holds about 2 600, and 10^5 already takes Snakemake minutes.
MAX_SAMPLES = 100_000


def pressure_label(p) -> str:
    """A pressure as it appears in paths (p1e-07, p0.0001, ...)."""
    return f"{float(p):g}"


def height_label(h) -> str:
    """A container height as it appears in paths (h8, h12.5)."""
    return f"h{float(h):g}"


def zeta_label(z) -> str:
    """A damping ratio as it appears in paths (zeta0.01)."""
    return f"{float(z):g}"


def _duplicate_key_loader():
    """A YAML SafeLoader that refuses a mapping key given twice (PyYAML keeps the last silently)."""
    import yaml

    class StrictLoader(yaml.SafeLoader):
        pass

    def construct_mapping(loader, node, deep=False):
        seen = {}
        for key_node, _value in node.value:
            key = loader.construct_object(key_node, deep=deep)
            try:
                first = seen.get(key)
            except TypeError:  # an unhashable key: let SafeLoader say so
                break
            if first is not None:
                raise _DuplicateKey(key, first.start_mark.line + 1, key_node.start_mark.line + 1)
            seen[key] = key_node
        return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)

    StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    return StrictLoader


class _DuplicateKey(Exception):
    def __init__(self, key, first, again):
        super().__init__(key)
        self.key, self.first, self.again = key, first, again


def _json_pairs(pairs):
    out = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key, None, None)
        out[key] = value
    return out


def read_config_file(path):
    """A workflow config file read as Snakemake reads it (JSON, else YAML), but strictly.

    Returns ``(config, None)`` or ``(None, message)``, the message one line naming the file:
    not UTF-8 text (a binary file), not JSON or YAML, a key given twice in one mapping (YAML
    and JSON loaders keep the last one silently), nested too deeply to read, or not a mapping
    of keys at the top level.
    """
    import yaml

    where = f"config: file {str(path)!r}"
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        return None, f"{where}: cannot be read ({exc.strerror or exc})"
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        return None, f"{where}: not a text file (byte {exc.start} is not UTF-8); give a YAML or JSON file"
    if "\0" in text:
        return None, f"{where}: not a text file (it holds NUL bytes); give a YAML or JSON file"
    try:
        try:
            obj = json.loads(text, object_pairs_hook=_json_pairs)
        except ValueError:  # not JSON (json.JSONDecodeError): YAML, as Snakemake reads it
            obj = yaml.load(text, Loader=_duplicate_key_loader())
    except _DuplicateKey as dup:
        at = f" (lines {dup.first} and {dup.again})" if dup.first else ""
        return None, (f"{where}: key {dup.key!r} is given twice in one mapping{at}; a YAML or "
                      "JSON reader would silently keep the last one")
    except RecursionError:
        return None, f"{where}: nested too deeply to read"
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        return None, f"{where}: not valid YAML or JSON{at}: {problem}"
    if not isinstance(obj, dict):
        return None, (f"{where}: must be a mapping of keys (name: value) at the top level, "
                      f"got {type(obj).__name__ if obj is not None else 'an empty file'}")
    return obj, None


def config_file_error(path) -> str | None:
    """:func:`read_config_file`'s message, or None when the file reads cleanly."""
    return read_config_file(path)[1]


def nonfinite_error(config) -> str | None:
    """The first number of ``config`` that is not finite (NaN, ±inf) or too large for a float,
    as one line naming its key; None if there is none. No config value may be either, and
    JSON-schema bounds let NaN through (every comparison with NaN is false)."""
    import sys

    stack = [((), config)]
    while stack:
        path, node = stack.pop()
        if isinstance(node, dict):
            stack.extend(((*path, k), v) for k, v in reversed(list(node.items())))
        elif isinstance(node, (list, tuple)):
            stack.extend(((*path, i), v) for i, v in reversed(list(enumerate(node))))
        elif isinstance(node, float) and not math.isfinite(node):
            return f"config: {_key(path)}: must be a finite number, got {node!r}"
        elif isinstance(node, int) and not isinstance(node, bool) and abs(node) > sys.float_info.max:
            return (f"config: {_key(path)}: must be a number within the range of a float "
                    f"(|x| <= {sys.float_info.max:.4g}), got an integer of about {int(abs(node).bit_length() * 0.30103) + 1} digits")
    return None


#: Characters a path in the config may hold: it goes unquoted into the jobs' shell commands.
_PATH_CHARS = r"A-Za-z0-9._/+,=@%:~-"


def results_error(results, key: str = "results") -> str | None:
    """The results folder as one line naming ``key`` if no job could write under it; else None.

    It must be a non-empty path of safe characters (it goes unquoted into every job's shell
    command and into the rules' path patterns, where a brace would be a wildcard), its parts
    must fit a file name, no part of it may be an existing file, and the deepest existing
    folder on it must let this user create folders (checked by making and removing one).
    """
    import os
    import re
    import tempfile

    value = str(results)
    where = f"config: {key} = {value!r}"
    if not value.strip():
        return f"config: {key}: must name a folder, got an empty path"
    bad = re.search(f"[^{_PATH_CHARS}]", value)
    if bad:
        return (f"{where}: {bad.group()!r} is not allowed in the results folder (it goes unquoted "
                "into every job's command): use letters, digits and . _ - / + , = @ % : ~")
    path = Path(value)
    for part in path.parts:
        if len(part.encode()) > 255:
            return f"{where}: the folder name {part[:20]!r}... is longer than 255 bytes"
    probe = path
    while not probe.exists():
        if probe.is_symlink():
            return f"{where}: {str(probe)!r} is a broken symbolic link"
        parent = probe.parent
        if parent == probe:
            break
        probe = parent
    if probe.exists() and not probe.is_dir():
        what = "the results folder" if probe == path else "a folder on its path"
        return f"{where}: {str(probe)!r} is a file, not a folder ({what})"
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".granwave-probe-", dir=probe))
    except OSError as exc:
        return f"{where}: cannot create folders in {str(probe)!r} ({exc.strerror or exc})"
    return None


def _label_lists(config):
    """(config key, values, wildcard, label function) of every list (or single value) that
    becomes part of a path."""
    p_label = ("pressure", pressure_label)
    h_label = ("size", height_label)
    out = []
    for scene, spec in (config.get("disordered") or {}).items():
        base = f"disordered.{scene}"
        out += [(f"{base}.pressures", spec["pressures"], *p_label),
                (f"{base}.heights", spec["heights"], *h_label)]
        if spec.get("series"):
            out += [(f"{base}.series.pressures", spec["series"]["pressures"], *p_label),
                    (f"{base}.series.heights", spec["series"]["heights"], *h_label)]
    for scene, spec in (config.get("lattices") or {}).items():
        out += [(f"lattices.{scene}.pressures", spec["pressures"], *p_label),
                (f"lattices.{scene}.rows", spec["rows"], "size", lambda r: f"r{r}")]
    for scene, spec in (config.get("chains") or {}).items():
        out += [(f"chains.{scene}.pressure", spec["pressure"], *p_label),
                (f"chains.{scene}.balls", spec["balls"], "size", lambda n: f"n{n}")]
    for scene, spec in (config.get("continuum") or {}).items():
        out += [(f"continuum.{scene}.pressure", spec["pressure"], *p_label),
                (f"continuum.{scene}.heights", spec["heights"], *h_label)]
    damping = config.get("damping") or {}
    if damping.get("enabled"):
        out.append(("damping.zetas", damping["zetas"], "zeta", zeta_label))
    return out


def labels_error(config: dict) -> str | None:
    """The first value (pressure, height, rows, balls, ζ) of a (schema-valid, defaulted) config
    whose path label does not fit the workflow's wildcard, or that gives the same label as an
    earlier value of the same list (two samples, or two batch outputs, with one path), as one
    line naming its key; None if there is none."""
    import re

    for key, values, wildcard, label in _label_lists(config):
        items = list(enumerate(values)) if isinstance(values, list) else [(None, values)]
        seen = {}
        for i, value in items:
            where = key if i is None else f"{key}[{i}]"
            text = label(value)
            if not re.fullmatch(WILDCARDS[wildcard], text):
                return (f"config: {where} = {value!r}: its path label {text!r} does not fit the "
                        f"workflow's {wildcard} pattern {WILDCARDS[wildcard]} (labels are written "
                        "with 6 significant digits, without an exponent only between 1e-4 and 1e6)")
            if text in seen:
                j = seen[text]
                return (f"config: {where} = {value!r} gives the same path label {text!r} as "
                        f"{key}[{j}] = {values[j]!r} (labels keep 6 significant digits): give "
                        "each value once")
            seen[text] = i
    return None


def sample_count(kind: str, spec: dict) -> int:
    """Samples of one (schema-valid, defaulted) scene, counted without listing them: an upper
    bound where a height series repeats a (pressure, height) of the scene."""
    if kind == "disordered":
        n = len(spec["pressures"]) * len(spec["heights"]) * spec["seeds"]
        series = spec.get("series")
        if series:
            n += len(series["pressures"]) * len(series["heights"]) * series["seeds"]
        return n
    if kind == "lattices":
        return len(spec["pressures"]) * len(spec["rows"])
    if kind == "chains":
        return len(spec["balls"]) * spec["seeds"]
    below = spec.get("seeds_below") or {"height": -math.inf, "seeds": 0}
    return sum(max(spec["seeds"], below["seeds"]) if h <= below["height"] else spec["seeds"]
               for h in spec["heights"])


def count_error(config: dict) -> str | None:
    """One line naming the largest scene if the config holds more than :data:`MAX_SAMPLES`
    samples (checked before any sample is listed: a count of 10^12 would never finish)."""
    counts = [(sample_count(kind, spec), kind, scene)
              for kind in SCENE_KINDS for scene, spec in (config.get(kind) or {}).items()]
    total = sum(n for n, _, _ in counts)
    if total <= MAX_SAMPLES:
        return None
    n, kind, scene = max(counts)
    spec = config[kind][scene]
    seeds = max(spec.get("seeds", 0), (spec.get("series") or {}).get("seeds", 0),
                (spec.get("seeds_below") or {}).get("seeds", 0))
    key = f"{kind}.{scene}" + (f".seeds = {seeds}" if seeds > 1 else "")
    return (f"config: {key}: {n:.3g} samples ({total:.3g} in all); a workflow holds at most "
            f"{MAX_SAMPLES} (every sample's files are named in the job graph): split the study "
            "over several configs")


def refusal(cls, values: dict) -> str | None:
    """What ``cls(**values)`` (a stage's Params, granwave/params.py) refuses, or None."""
    from .errors import InputError

    try:
        cls(**values)
    except InputError as exc:
        return str(exc)
    return None


def params_error(cls, values: dict, keys: dict, context: str = "") -> str | None:
    """``cls(**values)`` through its own checks (granwave/params.py); an InputError becomes one
    line naming the config key of the field it is about (``keys``: field -> config key; the
    message of a Params check starts with the field's name). None if the stage accepts them."""
    text = refusal(cls, values)
    if text is None:
        return None
    key = keys.get(text.split(" ", 1)[0]) or ", ".join(dict.fromkeys(keys.values()))
    return f"config: {key}: {text}{context}"


def analyses_error(config: dict, *, damping_t_max=None, snapshot=None) -> str | None:
    """The per-scene and study jobs' parameters through their stages' Params, as one line
    naming the config key: the height series' edge heights (``analyze heights``), each
    continuum scene's bootstrap (``analyze attenuation``), each DEM damping pulse
    (``propagate --method dem``, record ``damping_t_max``) and the snapshot signal
    (``snapshot``: its ``(t_max, times)``, None where the workflow makes none)."""
    from .params import AttenuationParams, HeightsParams, PropagateParams

    message = params_error(HeightsParams, {"edge_heights": config["edge_heights"]},
                           {"edge_heights": "edge_heights"})
    if message:
        return message
    for scene, spec in (config.get("continuum") or {}).items():
        message = params_error(AttenuationParams, {"bootstrap": spec["bootstrap"]},
                               {"bootstrap": f"continuum.{scene}.bootstrap"})
        if message:
            return message
    damping = config.get("damping") or {}
    if damping.get("enabled"):
        for i, zeta in enumerate(damping["zetas"]):
            message = params_error(
                PropagateParams,
                dict(method="dem", ic=config["ic"], t_max=damping_t_max, samples=config["samples"],
                     amplitude=damping["amplitude"], damping=float(zeta_label(zeta))),
                {"damping": f"damping.zetas[{i}]", "amplitude": "damping.amplitude",
                 "t_max": "t_max_factor", "samples": "samples", "ic": "ic"},
                f" (damping pulse zeta{zeta_label(zeta)})")
            if message:
                return message
    if snapshot is not None:
        t_max, times = snapshot
        message = params_error(PropagateParams, dict(method="time", ic=config["ic"], t_max=t_max,
                                                     snapshots=times),
                               {"snapshot": "t_max_factor", "t_max": "t_max_factor", "ic": "ic"},
                               " (the snapshot figure's signal)")
        if message:
            return message
    return None


def shear_record_length(height: float, speed: float, *, record: float, wavelengths) -> float:
    """Record of a shear-scene signal: ``record`` crossings at ``speed`` plus four periods of the
    longest source wavelength (the Ricker pulse is centred at 1.5/f and the phase pick windows to
    twice the arrival)."""
    return (record * height + 4.0 * max(wavelengths)) / speed


def shear_error(config: dict) -> str | None:
    """The first problem of a (schema-valid, defaulted) config's shear scenes, as one line naming
    the key: the source scene must be a frictional disordered scene with moduli, and every
    selected pressure and height one of its own; each scene's signals pass PropagateParams'
    checks (the record estimated from the lattice shear speed, an upper bound of c_t)."""
    from .params import PropagateParams
    from .theory import lattice_shear_speed

    disordered = config.get("disordered") or {}
    for scene, spec in (config.get("shear") or {}).items():
        base = f"shear.{scene}"
        for kind in SCENE_KINDS:
            if scene in (config.get(kind) or {}):
                return f"config: scene {scene!r} is defined twice ({kind}.{scene} and {base})"
        src = spec["scene"]
        if src not in disordered:
            have = ", ".join(disordered) or "none"
            return f"config: {base}.scene = {src!r} is not a disordered scene; disordered scenes: {have}"
        s = disordered[src]
        if not s["friction"] > 0:
            return (f"config: {base}.scene = {src!r} is frictionless (friction 0): the shear kick "
                    "needs tangential wall contacts (docs/shear.md)")
        if not s.get("moduli", True):
            return f"config: {base}.scene = {src!r} has moduli: false; the shear scene needs its c_t and c_l"
        series = s.get("series") or {"pressures": [], "heights": []}
        all_p = list(s["pressures"])
        all_h = list(s["heights"]) + list(series["heights"])
        for i, p in enumerate(spec.get("pressures") or []):
            if p not in all_p:
                return (f"config: {base}.pressures[{i}] = {p:g} is not a pressure of disordered.{src} "
                        f"({', '.join(f'{q:g}' for q in all_p)})")
        for i, h in enumerate(spec.get("heights") or []):
            if h not in all_h:
                return (f"config: {base}.heights[{i}] = {h:g} is not a height of disordered.{src} "
                        f"({', '.join(f'{q:g}' for q in sorted(set(all_h)))})")
        lams = spec["wavelengths"]
        p_low = min(spec.get("pressures") or all_p)
        h_top = max(spec.get("heights") or all_h)
        t_max = shear_record_length(h_top, float(lattice_shear_speed(p_low, poisson=s["poisson"])),
                                    record=spec["record"], wavelengths=lams)
        speed = float(lattice_shear_speed(p_low, poisson=s["poisson"]))
        needed = (h_top + max(lams)) / speed  # the arrival at an upper bound of c_t, then one period
        if t_max < needed:
            return (f"config: {base}.record = {spec['record']:g}: the shear record of the tallest column (height "
                    f"{h_top:g}, p = {p_low:g}) ends at t = {t_max:.4g}, before the pulse of wavelength "
                    f"{max(lams):g} can have passed (arrival not before {h_top / speed:.4g} at the lattice's "
                    f"shear speed, then one period): it needs t_max >= {needed:.4g}, a record of at least "
                    f"{math.ceil(1000 * (1.0 - 3.0 * max(lams) / h_top)) / 1000:g}")
        message = params_error(PropagateParams,
                               dict(method=spec["method"], ic="A", source_kind="shear", t_max=t_max,
                                    samples=spec["samples"], safety=spec["time_safety"]),
                               {"t_max": f"{base}.record", "samples": f"{base}.samples",
                                "safety": f"{base}.time_safety", "method": f"{base}.method"}, f" (shear scene {scene})")
        if message:
            return message
    return None


#: Set (to anything but "" or "0") where the workflow's GPU jobs run on other machines than the
#: one that plans them (a cluster's login node submits to GPU nodes): device: gpu is then not
#: checked against this machine.
GPU_ELSEWHERE_ENV = "GRANWAVE_GPU_ELSEWHERE"


def device_error(config: dict, gpu_usable=None) -> str | None:
    """One line if ``device: gpu`` is asked for and no CUDA GPU is usable on this machine (a dry
    run passed it, and every GPU job then failed), unless GPU_ELSEWHERE_ENV says that the GPU
    jobs run elsewhere. ``gpu_usable``: the check (default granwave.devices.require("gpu"), which
    raises InputError with the reason); only called for device gpu."""
    if config.get("device", "cpu") != "gpu" or os.environ.get(GPU_ELSEWHERE_ENV, "") not in ("", "0"):
        return None
    from .errors import InputError

    if gpu_usable is None:
        from .devices import require

        def gpu_usable():
            require("gpu")
    try:
        gpu_usable()
    except InputError as exc:
        reason = str(exc).split(": ", 1)[-1].split(";")[0]
        return (f"config: device = gpu: {reason}; use device: cpu, or set {GPU_ELSEWHERE_ENV}=1 where "
                "the GPU jobs run on other machines (a cluster's GPU nodes)")
    return None


def width_error(config: dict) -> str | None:
    """One line naming the key if a disordered or continuum scene's width is below what the DEM
    engine accepts: a periodic length of more than twice (the largest diameter + the skin)
    for unique nearest images (granwave.dem.integrator; the largest diameter of polydispersity w
    is 1 + w). A dry run passed widths of 1 and 1.5 d that every job then refused."""
    from .params import PrepareParams

    skin = float(PrepareParams.skin)
    for kind in ("disordered", "continuum"):
        for scene, spec in (config.get(kind) or {}).items():
            w = float(spec.get("polydispersity", 0.2))
            need = 2.0 * (1.0 + w + skin)
            if not float(spec["width"]) > need:
                return (f"config: {kind}.{scene}.width = {float(spec['width']):g}: narrower than the DEM's "
                        f"periodic limit, more than 2 x (largest diameter {1 + w:g} + skin {skin:g}) = "
                        f"{need:g} d")
    return None


def shocks_error(config: dict) -> str | None:
    """The first problem of a (schema-valid, defaulted) config's shocks scenes, as one line naming
    the key: a name used by another section, the contact sub-models (as a disordered scene's),
    the preparation's options (PrepareParams), drives that do not start in the linear regime
    or repeat a path label, a damping the pulse refuses."""
    from .analysis.shocks_scene import LINEAR_LIMIT
    from .dem.params import PrepareParams

    for scene, spec in (config.get("shocks") or {}).items():
        base = f"shocks.{scene}"
        for kind in (*SCENE_KINDS, "shear"):
            if scene in (config.get(kind) or {}):
                return f"config: scene {scene!r} is defined twice ({kind}.{scene} and {base})"
        message = contact_error({"disordered": {scene: spec}})
        if message:
            return message.replace(f"disordered.{scene}.", f"{base}.")
        drives = [float(d) for d in spec["drives"]]
        if min(drives) > LINEAR_LIMIT:
            return (f"config: {base}.drives: the weakest drive ({min(drives):g}) must be at most "
                    f"{LINEAR_LIMIT:g}: it gives each packing's linear speed c0")
        labels = [f"{d:g}" for d in drives]
        if len(set(labels)) != len(labels):
            return f"config: {base}.drives: two drives give one label ({', '.join(labels)})"
        if len(set(f"{float(p):g}" for p in spec["pressures"])) != len(spec["pressures"]):
            return f"config: {base}.pressures: a pressure is given twice"
        height, width = float(spec["height"]), int(spec["width"])
        for i, p in enumerate(spec["pressures"]):
            try:
                PrepareParams(dim=2, grains=max(1, round(width * height)), aspect=height / width,
                              pressure=float(p), friction=float(spec["friction"]),
                              poisson=float(spec["poisson"]), polydispersity=float(spec["polydispersity"]),
                              tol=float(spec["tol"]), max_steps=int(spec["max_steps"]), seed=0,
                              **(spec.get("contact") or {}))
            except (ValueError, TypeError) as e:
                return f"config: {base}.pressures[{i}]: {str(e).splitlines()[0]}"
    return None
