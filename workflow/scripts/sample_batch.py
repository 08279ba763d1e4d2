"""Run the per-sample pipeline of a batch of samples in one process (workflow/rules/batches.smk).

One interpreter and one numba start-up per batch instead of one per stage and sample;
every sample's files keep their usual names (results/<stage>/<scene>/p<p>/<size>/s<seed>.*)
and are written atomically as each finishes. The per-stage CPU times of every sample go
to the batch's timing table (read by benchmarks/workflow_runtime.py).
"""

import csv
import signal
import sys

from granwave.errors import ConvergenceError, InputError
from granwave.threads import set_threads
from granwave.workflow_support import run_sample


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM (Snakemake, a scheduler): atomic writes remove their temporary file


signal.signal(signal.SIGTERM, _interrupt)
set_threads(snakemake.threads)
sys.argv = ["workflow/scripts/sample_batch.py", snakemake.rule]  # provenance: command_line
FIELDS = ["scene", "pressure", "size", "seed", "stage", "n_grains", "n_dof", "steps", "cpu_s", "wall_s"]

with open(snakemake.log[0], "w") as log:
    rows = []
    for sample in snakemake.params.samples:
        try:
            timings = run_sample(sample, log=lambda line: print(line, file=log, flush=True))
        except (InputError, ConvergenceError) as exc:
            print(f"{sample['out']['summary']}: {exc}", file=log)
            sys.exit(1)
        rows += [{**{k: sample[k] for k in ("scene", "pressure", "size", "seed")}, **t} for t in timings]
    with open(snakemake.output.timings, "w", newline="") as f:
        writer = csv.DictWriter(f, FIELDS, delimiter="\t")
        writer.writeheader()
        writer.writerows({k: r[k] for k in FIELDS} for r in rows)
