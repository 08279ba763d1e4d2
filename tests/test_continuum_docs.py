"""docs/continuum.md's results are what benchmarks/results/summarize.py writes from the newest
continuum_scene.jsonl record of each scene (rerun it after recording a run)."""

from pathlib import Path

from test_generated_docs import _summarize

ROOT = Path(__file__).resolve().parents[1]


def test_docs_continuum_results_are_the_generated_ones():
    summarize = _summarize()
    doc = (ROOT / "docs" / "continuum.md").read_text()
    begin, end = summarize.CONTINUUM_TABLE
    block = doc[doc.index(begin) + len(begin):doc.index(end)]
    generated = summarize.continuum_scene_tables().strip()
    assert generated, "no continuum_scene.jsonl record"
    assert block.strip() == generated


def test_every_recorded_scene_has_its_candidate_table_and_continuum_length():
    text = _summarize().continuum_scene_tables()
    headings = [line for line in text.splitlines() if line.startswith("### ")]
    scenes = len([h for h in headings if not h.startswith("### The medium or the waveguide")])
    assert scenes >= 1
    assert text.count("| rule | tolerance |") == scenes
    assert text.count("Continuum length in frequency") == scenes
