"""Keep the measured tables in the docs equal to the run directories that produced them.

A Markdown page quotes a table of a benchmark run by a marked block:

    <!-- from benchmarks/results/lip_table2/tables.md: Table II -->
    | Method | SR [95% CI] (n) | ... |
    |---|---|...|
    <!-- end -->

The text after the colon names a `## ` section of that `tables.md` (matched by prefix;
`summary` means the run's header bullets: plant, setting, seeds done, commit; `table` the
table of a result file without sections, e.g. `benchmarks/results/walking_rates.md`). `sync`
rewrites every block from its file; `check` lists the blocks that differ, so a test keeps
the docs honest: a re-run benchmark whose tables changed fails until the docs are synced
(`python scripts/sync_results_doc.py`).
"""

from __future__ import annotations

import re
from pathlib import Path

from emonav_drake.errors import UserError

_BLOCK = re.compile(
    r"(?P<open><!-- from (?P<file>[^:>]+?): (?P<section>[^>]+?) -->\n)"
    r"(?P<body>.*?)"
    r"(?P<close><!-- end -->)",
    re.DOTALL,
)


class ResultsDocError(UserError, ValueError):
    """A block names a file or section that does not exist."""


def section_of(tables_md: Path, section: str) -> str:
    """The tables (and table notes) of one `## ` section of a run's `tables.md`.

    `summary`: the bullet lines before the first section. `table`: the table rows before
    the first section (a result file that is one table, or a run's README). Otherwise the
    lines of the first section whose heading starts with `section`, up to the next
    heading, blank lines at both ends removed; only table rows are kept, so the prose of
    `tables.md` (which repeats the definitions) does not clutter the page.
    """
    if not tables_md.is_file():
        raise ResultsDocError(f"{tables_md}: no such file")
    lines = tables_md.read_text().splitlines()
    if section in ("summary", "table"):
        mark = "- " if section == "summary" else "|"
        out = []
        for line in lines:
            if line.startswith("## "):
                break
            if line.startswith(mark):
                out.append(line)
        if not out:
            raise ResultsDocError(f"{tables_md}: no {section} before the first section")
        return "\n".join(out) + "\n"
    start = next(
        (i for i, line in enumerate(lines) if line.startswith(f"## {section}")),
        None,
    )
    if start is None:
        raise ResultsDocError(f"{tables_md}: no section starting with {section!r}")
    body = []
    for line in lines[start + 1 :]:
        if line.startswith("## "):
            break
        if line.startswith("|"):
            body.append(line)
    if not body:
        raise ResultsDocError(f"{tables_md}: section {section!r} holds no table")
    return "\n".join(body) + "\n"


def _render(text: str, root: Path) -> tuple[str, list[str]]:
    stale: list[str] = []

    def replace(m: re.Match) -> str:
        fresh = section_of(root / m["file"], m["section"].strip())
        if m["body"] != fresh:
            stale.append(f"{m['file']}: {m['section'].strip()}")
        return m["open"] + fresh + m["close"]

    return _BLOCK.sub(replace, text), stale


def quoted_blocks(doc: Path) -> list[str]:
    """The blocks of `doc` as `file: section`, in order (an opening comment without its
    `<!-- end -->` is not a block)."""
    return [f"{m['file']}: {m['section'].strip()}" for m in _BLOCK.finditer(doc.read_text())]


def check(doc: Path, root: Path) -> list[str]:
    """The blocks of `doc` (paths relative to `root`) that differ from their run files."""
    return _render(doc.read_text(), root)[1]


def sync(doc: Path, root: Path) -> list[str]:
    """Rewrite every block of `doc` from its run file; return those that changed."""
    text, stale = _render(doc.read_text(), root)
    if stale:
        doc.write_text(text)
    return stale
