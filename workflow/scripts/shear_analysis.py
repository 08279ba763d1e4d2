"""The shear scene's analysis (granwave.analysis.shear_scene): V_s(p), V_p(p), G_max(p),
V_p/V_s and the Poisson ratio from waves and from the moduli, the pick table; with an output
named ``figure`` (rule shear_scene_outputs) also the scene's figure, as `granwave plot shear`."""

import json
import sys

from granwave.analysis.shear_scene import shear_scene
from granwave.errors import InputError
from granwave.io.files import atomic_text, jsonable

with open(snakemake.log[0], "w") as log:
    records = [json.load(open(path)) for path in snakemake.input]
    skipped = [r for r in records if r.get("error")]
    for r in skipped:
        print(f"skipped: {r['error']}", file=log)
    try:
        result = shear_scene([r for r in records if not r.get("error")], pick=snakemake.params.pick,
                             material=snakemake.params.material, diameter_mm=snakemake.params.diameter_mm,
                             poisson=snakemake.params.poisson)
    except InputError as exc:
        print(f"shear analysis: {exc}", file=log)
        sys.exit(1)
    result.update(scene=snakemake.wildcards.scene, source_scene=snakemake.params.source,
                  n_skipped=len(skipped))
    text = json.dumps(jsonable(result), indent=1) + "\n"
    atomic_text(snakemake.output[0], text)
    figure = getattr(snakemake.output, "figure", None)  # rule shear_scene_outputs: the figure too
    if figure:  # in this process: a `granwave plot shear` job of its own costs ~1.5 CPU-s of start-up
        import matplotlib

        matplotlib.use("Agg")
        from granwave.figures.shear import shear_panels

        shear_panels(json.loads(text), figure, scene=snakemake.wildcards.scene)

