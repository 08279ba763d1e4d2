"""The workflow's job counts and measured run times quoted in README.md and config/README.md
are generated (benchmarks/results/summarize.py: `snakemake -n` per config, run times from
benchmarks/results/workflow.jsonl), and the text in the repository is what the generator
writes now. After changing the workflow or measuring a run: python benchmarks/results/summarize.py
"""

import importlib.util
from pathlib import Path

import pytest

from quick_plan import dry_run

ROOT = Path(__file__).resolve().parents[1]


def _summarize():
    spec = importlib.util.spec_from_file_location("summarize", ROOT / "benchmarks" / "results" / "summarize.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _spans(text):
    return [(m.group("name"), m.group("text")) for m in _summarize()._SPAN.finditer(text)]


def test_run_times_in_the_docs_come_from_workflow_jsonl():
    summarize = _summarize()
    runs = summarize.workflow_runs()
    wall = runs[-1]["summary"]["wall (s)"]
    spans = [s for doc in summarize.GENERATED_DOCS for s in _spans((ROOT / doc).read_text())]
    about = [text for name, text in spans if name == "workflow-about"]
    assert about and all(text == f"about {round(wall / 60)} min" for text in about), about
    for name, text in spans:
        if not name.startswith("jobs "):
            assert text == summarize.generated_value(name), (name, text)


@pytest.mark.parametrize("config", [
    "config/config.yaml",
    pytest.param("config/paper.yaml", marks=pytest.mark.slow),  # its dry run takes ~14 CPU-s
])
def test_job_counts_in_the_docs_are_current(config):
    summarize = _summarize()
    quoted = {text for doc in summarize.GENERATED_DOCS for name, text in _spans((ROOT / doc).read_text())
              if name == f"jobs {config}"}
    assert quoted, f"no generated job count of {config} in the docs"
    count = summarize.jobs_of_plan(*dry_run(config), config)  # the dry run workflow_jobs makes
    assert quoted == {str(count)}, (f"the docs say {quoted} jobs for {config}, snakemake -n counts {count}: "
                                    "run python benchmarks/results/summarize.py")


def test_the_generator_rewrites_only_the_spans(tmp_path):
    summarize = _summarize()
    for doc in summarize.GENERATED_DOCS:
        (tmp_path / doc).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / doc).write_text((ROOT / doc).read_text())
    out = summarize.generated_docs(tmp_path, jobs=lambda config: 999)
    readme = out[tmp_path / "README.md"]
    assert "<!-- gen:jobs config/config.yaml -->999<!-- /gen --> jobs" in readme
    def blank(text):
        return summarize._SPAN.sub(lambda m: m.group(1) + m.group(4), text)
    for doc in summarize.GENERATED_DOCS:
        assert blank(out[tmp_path / doc]) == blank((ROOT / doc).read_text())
