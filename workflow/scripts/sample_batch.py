"""Run the per-sample pipeline of a batch of samples in one process (workflow/rules/batches.smk).

One interpreter and one numba start-up per batch instead of one per stage and sample;
every sample's files keep their usual names (results/<stage>/<scene>/p<p>/<size>/s<seed>.*)
and are written atomically as each finishes, and kept in the batch's finished-sample store
(results/finished/<batch>/, granwave.finished_store) until the batch ends, so that a batch cut
by a time limit, Ctrl-C or a crash restores them when it runs again instead of computing them.
The per-stage CPU times of every sample go to the batch's timing table (read by
benchmarks/workflow_runtime.py).
"""

import os
import signal
import sys

from granwave.threads import set_threads
from granwave.workflow_support import run_batch, run_sample


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM (Snakemake, a scheduler): atomic writes remove their temporary file


signal.signal(signal.SIGTERM, _interrupt)
set_threads(snakemake.threads)
sys.argv = ["workflow/scripts/sample_batch.py", snakemake.rule]  # provenance: command_line
FIELDS = ["scene", "pressure", "size", "seed", "stage", "n_grains", "n_dof", "steps", "cpu_s", "wall_s"]

run_batch(run_sample, snakemake.params.samples, log_path=snakemake.log[0],
          timings_path=snakemake.output.timings, fields=FIELDS, failed_key="summary",
          store=os.path.join(snakemake.config["results"], "finished", snakemake.rule))
