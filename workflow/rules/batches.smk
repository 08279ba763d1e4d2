# Batches: the whole per-sample pipeline (make the sample, linearize, signal, statics,
# moduli, front, summary) of up to `batch_size` samples in one job, i.e. one Python process.
# Measured: a `granwave` command costs ~1 s of start-up (interpreter, imports, numba cache),
# more than most per-sample stages themselves (config/README.md).
#
# One rule per batch with its files named explicitly: the per-sample files keep their
# names, and Snakemake prefers a rule without wildcards over the per-sample rules of
# packings.smk / linear.smk / analysis.smk, which still make any single file on request
# (e.g. the modes of the spectrum figure).


for _name, _scene, _samples in batches():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        input:
            kernels_of(_scene),
            [s["out"]["packing"] for s in _samples if s.get("packing_given")],  # device gpu
        output:
            [path for s in _samples for stage, path in s["out"].items()
             if not (stage == "packing" and s.get("packing_given"))],
            timings=f"{R}/timings/{_name}.tsv",
        log:
            f"{R}/logs/batch/{_name}.log",
        benchmark:
            f"{R}/benchmarks/batch/{_name}.tsv"
        params:
            samples=_samples,
        threads: batch_threads(_samples)
        priority: batch_priority(_samples)
        resources:
            mem_mb=2000,
            runtime=60,
        script:
            "../scripts/sample_batch.py"
