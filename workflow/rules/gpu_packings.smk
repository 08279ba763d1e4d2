# device: gpu (config): every height of a disordered or continuum scene has one job that prepares
# all its seeds together on one GPU (prepare-packing --seeds --device gpu: ensembles per launch,
# docs/gpu.md); the batch jobs then read those packings instead of preparing them. Each packing
# is the one its seed gives alone on the GPU. With device: cpu (the default) there is no such job.


for _name, _group in gpu_packings():

    rule:
        name:
            _name
        conda:
            "../envs/granwave.yaml"
        output:
            [s["out"]["packing"] for s in _group],
        log:
            f"{R}/logs/gpu_packings/{_name}.log",
        benchmark:
            f"{R}/benchmarks/gpu_packings/{_name}.tsv"
        params:
            command=lambda wildcards, group=_group: gpu_packings_command(group),  # {seed}: no wildcard
        threads: 1
        resources:
            mem_mb=4000,
            runtime=60,
            gpu=1,
        shell:
            "{params.command} > {log} 2>&1"
