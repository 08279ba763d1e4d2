"""The shear scene's analysis (granwave.analysis.shear_scene): V_s(p), V_p(p), G_max(p),
V_p/V_s and the Poisson ratio from waves and from the moduli, the pick table."""

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
                             material=snakemake.params.material, diameter_mm=snakemake.params.diameter_mm)
    except InputError as exc:
        print(f"shear analysis: {exc}", file=log)
        sys.exit(1)
    result.update(scene=snakemake.wildcards.scene, source_scene=snakemake.params.source,
                  n_skipped=len(skipped))
    atomic_text(snakemake.output[0], json.dumps(jsonable(result), indent=1) + "\n")
