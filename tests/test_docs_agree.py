"""The docs quote measured tables from the run directories that produced them, unchanged."""

from pathlib import Path

import pytest

from emonav_drake.evaluation.results_doc import ResultsDocError, check, section_of, sync

ROOT = Path(__file__).resolve().parent.parent


def test_every_quoted_table_equals_its_run_directory():
    docs = sorted((ROOT / "docs").glob("*.md"))
    quoted = sum(d.read_text().count("<!-- from benchmarks/results/") for d in docs)
    assert quoted >= 5  # results.md quotes the LIP and Digit runs
    stale = {d.name: check(d, ROOT) for d in docs}
    assert not any(stale.values()), f"run `python scripts/sync_results_doc.py`: {stale}"


def test_sync_rewrites_a_stale_block_and_names_bad_ones(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "tables.md").write_text(
        "# Benchmark run\n\n- plant: lip\n\n## Table II: SR\n\nprose\n\n| a | b |\n|---|---|\n"
        "| 1 | 2 |\n\n## Other\n\n| c |\n"
    )
    doc = tmp_path / "doc.md"
    doc.write_text("x\n<!-- from run/tables.md: Table II -->\n| old |\n<!-- end -->\ny\n")
    assert check(doc, tmp_path) == ["run/tables.md: Table II"]
    assert sync(doc, tmp_path) == ["run/tables.md: Table II"]
    assert doc.read_text() == (
        "x\n<!-- from run/tables.md: Table II -->\n| a | b |\n|---|---|\n| 1 | 2 |\n"
        "<!-- end -->\ny\n"
    )
    assert check(doc, tmp_path) == []
    assert section_of(run / "tables.md", "summary") == "- plant: lip\n"
    with pytest.raises(ResultsDocError, match="no section starting with 'Table IV'"):
        section_of(run / "tables.md", "Table IV")
    with pytest.raises(ResultsDocError, match="no such file"):
        section_of(tmp_path / "missing.md", "Table II")
