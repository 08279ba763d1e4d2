"""Run a shocks scene's packings of a batch in one process (workflow/rules/shocks.smk).

For each packing: its DEM preparation, then one piston push per drive and the packing's record
(granwave.workflow_support.run_shocks_sample). Per-stage CPU times go to the batch's timing table.
"""

import os
import signal
import sys

from granwave.threads import set_threads
from granwave.workflow_support import run_batch, run_shocks_sample


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM (Snakemake, a scheduler): atomic writes remove their temporary file


signal.signal(signal.SIGTERM, _interrupt)
set_threads(snakemake.threads)
sys.argv = ["workflow/scripts/shocks_batch.py", snakemake.rule]  # provenance: command_line
FIELDS = ["scene", "pressure", "size", "seed", "stage", "n_dof", "cpu_s", "wall_s"]

run_batch(run_shocks_sample, snakemake.params.samples, log_path=snakemake.log[0],
          timings_path=snakemake.output.timings, fields=FIELDS, failed_key="record",
          store=os.path.join(snakemake.config["results"], "finished", snakemake.rule))
