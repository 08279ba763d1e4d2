"""Compile the shocks scene's kernels (DEM preparation and piston pulse) into numba's cache before
its batches start together (workflow/rules/shocks.smk; granwave.workflow_support.warm_shocks)."""

import json
import sys
import tempfile

from granwave.workflow_support import warm_shocks

sys.argv = ["workflow/scripts/shocks_kernels.py"]
with open(snakemake.log[0], "w") as log, tempfile.TemporaryDirectory() as folder:
    done = warm_shocks(snakemake.params.sample.value, folder, log=lambda line: print(line, file=log, flush=True))
with open(snakemake.output[0], "w") as f:
    json.dump(done, f, indent=1)
