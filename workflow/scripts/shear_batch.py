"""Run the shear scene's per-packing work of a batch in one process (workflow/rules/shear.smk).

One interpreter and one numba start-up per batch: for each packing of the source scene, the
shear and compressional kicks (time domain) and every pick at each wavelength
(granwave.workflow_support.run_shear_sample). Per-stage CPU times go to the batch's timing
table (read by benchmarks/workflow_runtime.py).
"""

import csv
import signal
import sys

from granwave.errors import ConvergenceError, InputError
from granwave.threads import set_threads
from granwave.workflow_support import run_shear_sample


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM (Snakemake, a scheduler): atomic writes remove their temporary file


signal.signal(signal.SIGTERM, _interrupt)
set_threads(snakemake.threads)
sys.argv = ["workflow/scripts/shear_batch.py", snakemake.rule]  # provenance: command_line
FIELDS = ["scene", "pressure", "size", "seed", "stage", "n_dof", "cpu_s", "wall_s"]

with open(snakemake.log[0], "w") as log:
    rows = []
    for sample in snakemake.params.samples:
        try:
            timings = run_shear_sample(sample, log=lambda line: print(line, file=log, flush=True))
        except (InputError, ConvergenceError) as exc:
            print(f"{sample['out']['picks']}: {exc}", file=log)
            sys.exit(1)
        rows += [{**{k: sample[k] for k in ("scene", "pressure", "size", "seed")}, **t} for t in timings]
    with open(snakemake.output.timings, "w", newline="") as f:
        writer = csv.DictWriter(f, FIELDS, delimiter="\t")
        writer.writeheader()
        writer.writerows({k: r[k] for k in FIELDS} for r in rows)
