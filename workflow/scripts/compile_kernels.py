"""Compile one kernel family into numba's cache before the jobs that use it
(workflow/rules/compile.smk; granwave.workflow_support.warm_kernels)."""

import json
import sys
import tempfile

from granwave.workflow_support import warm_kernels

sys.argv = ["workflow/scripts/compile_kernels.py", snakemake.wildcards.family]
with open(snakemake.log[0], "w") as log, tempfile.TemporaryDirectory() as folder:
    done = warm_kernels(snakemake.wildcards.family, snakemake.params.samples.value, folder,
                        pulse=snakemake.params.pulse.value, log=lambda line: print(line, file=log, flush=True))
with open(snakemake.output[0], "w") as f:
    json.dump(done, f, indent=1)
