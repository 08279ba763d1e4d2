"""Run light `granwave` commands in one process: a scene's height series, ensembles and pressure
sweep (workflow/rules/analysis.smk), or the main study's figures (workflow/rules/report.smk).

Each command runs in this process as it would alone (granwave.workflow_support.run_command):
its files keep their usual names and bytes; one interpreter start-up per job instead of one per
command. The CPU seconds of every command go to the job's timing table.
"""

import signal

from granwave.workflow_support import run_batch, run_command


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM (Snakemake, a scheduler): atomic writes remove their temporary file


signal.signal(signal.SIGTERM, _interrupt)
KEYS = ("scene", "pressure", "size")
run_batch(run_command, snakemake.params.commands, log_path=snakemake.log[0],
          timings_path=snakemake.output.timings, fields=[*KEYS, "stage", "cpu_s", "wall_s"],
          failed_key="result", keys=KEYS)
