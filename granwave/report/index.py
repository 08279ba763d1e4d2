"""The study's report page: results/report/index.md and its HTML twin index.html.

:func:`build_report` assembles the sections of :mod:`granwave.report.tables`
from the analysis outputs; :func:`write_report` writes the Markdown and the
HTML (:mod:`granwave.report.html`) atomically. Every number on the page is
computed from the inputs:

* **per-sample summaries** (``results/summary/<scene>/p<p>/<size>/s<seed>.json``,
  layout in docs/summaries.md): statics, moduli, provenance tables per scene,
  pressure and container height, and the continuum speeds c_ℓ, c_t;
* **height series** (``granwave analyze heights --json``): c_tof, c_peak,
  c_zero with their standard errors, γ and δ;
* **pressure sweeps** (``granwave pressure-sweep --json``): their fits as given;
* **the theory** (:mod:`granwave.theory`): lattice speeds, the p^{1/6}
  exponent, the chain's exact γ and δ;
* **the damping table** (``granwave analyze damping --json``);
* **the continuum scenes** (``granwave analyze continuum`` and ``attenuation --json``,
  :mod:`granwave.report.continuum`);
* **the shear scenes** (``results/shear/<scene>/analysis.json``, :mod:`granwave.report.shear`);
* **figures**: every PNG given, linked relative to the page, captioned from its
  file name (:func:`granwave.report.captions.caption_for`).
"""

from __future__ import annotations

import os
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..analysis.renamed_keys import HEIGHTS, SWEEP, current_keys
from ..errors import InputError
from ..io.files import atomic_text
from . import findings as FI
from . import tables as T
from .continuum import continuum_inputs, continuum_section
from .html import markdown_to_html
from .inputs import Scenes, scene_of
from .laws import laws_section
from .shear import shear_inputs, shear_section
from .shocks import shocks_inputs, shocks_section
from .symbols import symbol_table


def build_report(*, summaries: Sequence[tuple[Path, object, str | None]] = (),
                 heights: Sequence[tuple[Path, object, str | None]] = (),
                 sweeps: Sequence[tuple[Path, object, str | None]] = (),
                 figures: Sequence[Path] = (), out_dir: Path = Path("."),
                 config: Mapping | None = None, config_path: str | None = None,
                 title: str = "granwave report", damping: Sequence[Mapping] = (),
                 continuum: Sequence[tuple[Path, object, str | None]] = (),
                 shear: Sequence[tuple[Path, object, str | None]] = (),
                 shocks: Sequence[tuple[Path, object, str | None]] = (),
                 timings: Sequence[Path] = ()) -> str:
    """The report as Markdown (sources: module docstring).

    ``summaries``, ``heights``, ``sweeps``: (path, object, scene guess) from
    :func:`granwave.report.collect_json`; ``damping``: rows of
    ``granwave analyze damping --json``; ``continuum``: (path, object, guess) of the
    continuum scenes' analyses (:mod:`granwave.report.continuum`); ``shear``: the shear scenes'
    analyses (:mod:`granwave.report.shear`); ``shocks``: the shocks scenes' analyses
    (:mod:`granwave.report.shocks`); ``timings``: the workflow's timing tables
    (results/timings/*.tsv) for the run's CPU time. Refuses (InputError) a call with no
    input at all: an empty report would look like a finished study.

    The page: a header, the findings (:mod:`granwave.report.findings`), the symbol table
    (:mod:`granwave.report.symbols`), then one section per entry of ``sections`` below, each
    under its anchor (the findings link to it). A new section is one more entry.
    """
    from .. import __version__
    from ..analysis.sweep import validate_summary
    from .captions import caption_for
    from ..provenance import git_revision

    if not (summaries or heights or sweeps or figures or damping or continuum or shear or shocks):
        raise InputError("nothing to report: give --summaries, --heights, --sweep, --figures "
                         "or --damping (files or folders that hold some)")
    sums = []
    for path, obj, guess in summaries:
        items = obj if isinstance(obj, list) else [obj]  # a file holds one summary or a list
        for k, item in enumerate(items):
            validate_summary(item, f"{path}" + (f"[{k}]" if isinstance(obj, list) else ""))
            sums.append({**item, "_scene": scene_of(path, item, guess), "_path": str(path)})
    hts = []
    for path, obj, guess in heights:
        if not isinstance(obj, Mapping):
            raise InputError(f"{path}: expected an `analyze heights --json` object")
        hts.append({**current_keys(obj, HEIGHTS), "_scene": scene_of(path, obj, guess),
                    "_path": str(path)})
    sweeps = [(path, current_keys(obj, SWEEP), guess) for path, obj, guess in sweeps]
    scenes = Scenes(config, sums)

    name = (config or {}).get("name") or (Path(config_path).stem if config_path else "(none given)")
    md = [f"# {_plain(title)}", ""]
    md += [f"- configuration: **{_plain(name)}**" + (f" (`{config_path}`)" if config_path else ""),
           f"- granwave {__version__}, git revision `{git_revision()}`",
           f"- inputs: {len(sums)} sample summaries, {len(hts)} height series, "
           f"{len(sweeps)} pressure sweeps, {len(figures)} figures",
           "- units (docs/method.md §1): lengths d̄, pressures and moduli E*, forces E* d̄², "
           "speeds √(E*/ρ), times d̄/√(E*/ρ); every table says which apply",
           "- numbers: value ± error with the error to 1–2 significant digits and the value "
           "rounded to match; counts as integers; a quantity over fewer than 5 packings as the "
           "range of their values (min … max), not a ± from so few; a positive quantity whose "
           "95 % interval reaches 0 or spans more than a decade as a bound, not an estimate; "
           "every table says which error its ± is", ""]

    per_scene: dict[str, list] = defaultdict(list)
    for s in sums:
        per_scene[s["_scene"]].append(s)
    groups = {scene: T.Groups(items) for scene, items in sorted(per_scene.items())}
    h_by_scene: dict[str, dict[float, Mapping]] = defaultdict(dict)
    for h in hts:
        if h.get("pressure") is not None:
            h_by_scene[h["_scene"]][T.pressure_key(h["pressure"])] = h

    dims = {name: int(spec.get("dim", 2)) for name, spec in ((config or {}).get("continuum") or {}).items()
            if isinstance(spec, Mapping)}
    cont, shr = continuum_inputs(continuum), shear_inputs(shear)
    sections = [  # (anchor, lines): the page's sections in order
        ("statics", T.statics_section(groups, scenes)),
        ("moduli", T.moduli_section(groups, scenes)),
        ("speeds", T.speeds_section(groups, h_by_scene, scenes)),
        ("exponents", T.exponents_section(hts, scenes, sorted(per_scene))),
        ("lattices", T.lattice_section(h_by_scene, scenes)),
        ("laws", laws_section(h_by_scene, scenes)),
        ("damping", T.damping_section(damping) if damping else []),
        ("continuum", continuum_section(cont, dims)),
        ("shear", shear_section(shr)),
        ("shocks", shocks_section(shocks_inputs(shocks))),
        ("sweeps", _sweeps_section(sweeps)),
        ("provenance", T.provenance_section(groups) if groups else []),
        ("figures", _figures_section(figures, out_dir, caption_for)),
    ]
    rows = (FI.pressure_rows(sweeps, groups) + FI.front_rows(h_by_scene, scenes, "exponents")
            + FI.lattice_rows(h_by_scene, scenes, "lattices")
            + FI.effective_medium_rows(groups, scenes, "moduli", config)
            + FI.continuum_rows(cont, "continuum") + FI.shear_rows(shr, "shear"))
    md += FI.findings_section(rows, FI.what_was_run(sums, scenes, timings, continuum=cont, shear=shr,
                                                      damping=damping))
    md += ['<a id="symbols"></a>', "", "## Symbols", "",
           "One symbol per quantity, on this page and in the figures; the JSON keys of the inputs "
           "in code font (renamed keys: docs/decisions/0038-one-symbol-per-quantity.md).", ""]
    md += symbol_table()
    for anchor, lines in sections:
        if lines:
            md += [f'<a id="{anchor}"></a>', ""] + lines
    return "\n".join(md).rstrip() + "\n"


def _sweeps_section(sweeps) -> list[str]:
    if not sweeps:
        return []
    md = ["## Pressure-sweep fits (`granwave pressure-sweep`)", "",
          "The fitted exponents κ (c ∝ p^κ) of each sweep file, as computed by `pressure-sweep` "
          "through the per-pressure means of the summaries — every height of a pressure pooled, "
          "so they differ from the per-height fits of the speeds section (dimensionless, ± one "
          "standard error of the fitted slope; pressures: how many the fit used; c_ℓ the whole "
          "cell's).", ""]
    for path, obj, _ in sweeps:
        label = obj.get("scene") if isinstance(obj, Mapping) and obj.get("scene") else Path(path).stem
        md += [f"### {label}", ""] + T.sweep_table(obj)
    return md


def _figures_section(figures, out_dir, caption_for) -> list[str]:
    md = ["## Figures", ""]
    if not figures:
        return md + ["No figures given.", ""]
    for f in figures:
        rel = Path(os.path.relpath(f, out_dir)).as_posix()
        cap = caption_for(f)
        md += [f"### {cap}", "", f"![{cap}]({rel})", ""]
        twin = Path(f).with_suffix(".pdf")
        if twin.exists() and twin != Path(f):
            md += [f"[PDF]({Path(os.path.relpath(twin, out_dir)).as_posix()})", ""]
    return md


def _plain(text) -> str:
    """User text (``--title``, the config's name) as literal text of one Markdown line: HTML
    special characters escaped (no markup reaches the HTML page), line breaks as spaces."""
    import html

    return " ".join(html.escape(str(text), quote=False).split())


def write_report(path, markdown: str, *, title: str = "granwave report") -> list[Path]:
    """Write ``path`` (Markdown) and the HTML twin beside it (same stem, .html), atomically."""
    path = Path(path)
    if path.suffix.lower() != ".md":
        raise InputError(f"{path}: the report must be a .md file")
    path.parent.mkdir(parents=True, exist_ok=True)
    html_path = path.with_suffix(".html")
    atomic_text(path, markdown)
    atomic_text(html_path, markdown_to_html(markdown, title))
    return [path, html_path]
