"""The docs quote measured tables from the run directories that produced them, unchanged;
every run directory, result file and figure they name exists in the repository."""

import re
from pathlib import Path

import pytest

from emonav_drake.evaluation.results_doc import (
    ResultsDocError,
    check,
    quoted_blocks,
    section_of,
    sync,
)

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

# `benchmarks/results/<run>/…` anywhere in a page: prose, commands, links.
_RESULT_PATH = re.compile(r"benchmarks/results/[A-Za-z0-9_./-]*")
# `![alt](path)`: a figure the page shows.
_FIGURE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)")


def _doc_id(doc: Path) -> str:
    return str(doc.relative_to(ROOT))


def test_the_docs_are_the_readme_and_every_page():
    names = {_doc_id(d) for d in DOCS}
    assert {"README.md", "docs/results.md", "docs/walking.md", "docs/rates.md"} <= names


@pytest.mark.parametrize("doc", DOCS, ids=_doc_id)
def test_every_quoted_table_equals_its_run_directory(doc):
    opened = doc.read_text().count("<!-- from ")
    assert len(quoted_blocks(doc)) == opened, (
        f"{_doc_id(doc)}: a `<!-- from … -->` without its `<!-- end -->`"
    )
    stale = check(doc, ROOT)
    assert not stale, f"run `python scripts/sync_results_doc.py`: {_doc_id(doc)}: {stale}"


def test_the_results_are_quoted():
    quoted = sum(len(quoted_blocks(d)) for d in DOCS)
    assert quoted >= 5  # results.md quotes the LIP and Digit runs


@pytest.mark.parametrize("doc", DOCS, ids=_doc_id)
def test_every_named_run_directory_and_result_file_exists(doc):
    named = {m.group(0).rstrip(".") for m in _RESULT_PATH.finditer(doc.read_text())}
    missing = sorted(p for p in named if not (ROOT / p).exists())
    assert not missing, f"{_doc_id(doc)} names results not in the repository: {missing}"


@pytest.mark.parametrize("doc", DOCS, ids=_doc_id)
def test_every_figure_exists(doc):
    links = [p for p in _FIGURE.findall(doc.read_text()) if "://" not in p]
    missing = sorted(p for p in links if not (doc.parent / p.split("#")[0]).is_file())
    assert not missing, f"{_doc_id(doc)} shows figures that do not exist: {missing}"


def test_sync_rewrites_a_stale_block_and_names_bad_ones(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "tables.md").write_text(
        "# Benchmark run\n\n- plant: lip\n\n## Table II: SR\n\nprose\n\n| a | b |\n|---|---|\n"
        "| 1 | 2 |\n\n## Other\n\n| c |\n"
    )
    doc = tmp_path / "doc.md"
    doc.write_text("x\n<!-- from run/tables.md: Table II -->\n| old |\n<!-- end -->\ny\n")
    assert quoted_blocks(doc) == ["run/tables.md: Table II"]
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
    with pytest.raises(ResultsDocError, match="no table before the first section"):
        section_of(run / "tables.md", "table")


def test_a_result_file_without_sections_is_quoted_whole(tmp_path):
    (tmp_path / "sweep.md").write_text("| rate | RMS |\n|---:|---:|\n| 1 kHz | 3.0 |\n")
    (tmp_path / "README.md").write_text(
        "# A run\n\nprose\n\n| a |\n|---|\n| 1 |\n\nmore prose\n\n## Later\n\n| b |\n"
    )
    assert (
        section_of(tmp_path / "sweep.md", "table")
        == "| rate | RMS |\n|---:|---:|\n| 1 kHz | 3.0 |\n"
    )
    assert section_of(tmp_path / "README.md", "table") == "| a |\n|---|\n| 1 |\n"
    doc = tmp_path / "doc.md"
    doc.write_text("<!-- from sweep.md: table -->\n| rate | RMS |\n<!-- end -->\n")
    assert check(doc, tmp_path) == ["sweep.md: table"]


def test_an_unclosed_block_is_not_a_block(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text("<!-- from run/tables.md: Table II -->\n| a |\n")
    assert quoted_blocks(doc) == []


def test_the_results_page_opens_with_the_shipped_default():
    """The first table of docs/results.md is quoted from a run (checked above) whose first
    row is the default policy, and that run ran the file shipped as the default."""
    import hashlib
    import json

    from emonav_drake.planners.policy import DEFAULT_POLICY

    page = ROOT / "docs" / "results.md"
    first = quoted_blocks(page)[0]
    text = page.read_text()
    assert text.index("<!-- from ") < text.index("\n| ")  # no table before the quoted one
    rows = [r for r in section_of(ROOT / first.split(":")[0], "table").splitlines()]
    assert rows[2].startswith("| policy (default, `distilled_digit_r2`)"), rows[2]
    for run in ("digit_distilled_r2", "lip_distilled_r2"):
        settings = json.loads((ROOT / "benchmarks/results" / run / "settings.json").read_text())
        ran = settings["methods"]["distilled_digit_r2"]["checkpoint_sha256"]
        assert ran == hashlib.sha256(DEFAULT_POLICY.read_bytes()).hexdigest(), run
