"""Run the shear scene's per-packing work of a batch in one process (workflow/rules/shear.smk).

One interpreter and one numba start-up per batch: for each packing of the source scene, the
shear and compressional kicks (time domain) and every pick at each wavelength
(granwave.workflow_support.run_shear_sample). Per-stage CPU times go to the batch's timing
table (read by benchmarks/workflow_runtime.py).
"""

import os
import signal
import sys

from granwave.threads import set_threads
from granwave.workflow_support import run_batch, run_shear_sample


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM (Snakemake, a scheduler): atomic writes remove their temporary file


signal.signal(signal.SIGTERM, _interrupt)
set_threads(snakemake.threads)
sys.argv = ["workflow/scripts/shear_batch.py", snakemake.rule]  # provenance: command_line
FIELDS = ["scene", "pressure", "size", "seed", "stage", "n_dof", "cpu_s", "wall_s"]

run_batch(run_shear_sample, snakemake.params.samples, log_path=snakemake.log[0],
          timings_path=snakemake.output.timings, fields=FIELDS, failed_key="picks",
          store=os.path.join(snakemake.config["results"], "finished", snakemake.rule))
