"""Merge one sample's analysis outputs (JSON) into its summary file (docs/summaries.md)."""

import json

from granwave.analysis.sweep import merge_summary
from granwave.io.files import read_signal

sections = {name: json.load(open(path)) for name, path in snakemake.input.items()
            if name in ("statics", "moduli", "front")}
attrs = read_signal(snakemake.input.signal).attrs
summary = merge_summary(attrs=attrs, scene=snakemake.wildcards.scene, **sections)
with open(snakemake.output[0], "w") as f:
    json.dump(summary, f, indent=1)
