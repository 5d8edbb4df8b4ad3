"""The documentation site (`mkdocs.yml`) builds with `mkdocs build --strict`: no broken
link or anchor, every API page's module resolves, and the pages show what the package's
docstrings and configuration say (BUILD.md, "The documentation site")."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

_UNRECOGNIZED = re.compile(r"Doc file '([^']+)' contains an unrecognized relative link '([^']+)'")


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> tuple[subprocess.CompletedProcess, Path]:
    """The site built strictly into a temporary directory, and its build log."""
    site = tmp_path_factory.mktemp("docs") / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    return proc, site


@pytest.mark.slow
def test_the_site_builds_strictly(built):
    proc, site = built
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert (site / "index.html").is_file()
    assert (site / "cli" / "index.html").is_file()


def test_no_link_is_left_unresolved(built):
    """A link MkDocs cannot classify (e.g. to a run directory outside docs/) is a warning
    (`mkdocs.yml`, `validation.unrecognized_links`), so the strict build fails on it; and
    none is in the log."""
    proc, _ = built
    assert sorted(set(_UNRECOGNIZED.findall(proc.stderr))) == []


def test_an_api_page_is_rendered_from_the_docstrings(built):
    _, site = built
    page = (site / "api" / "maths" / "index.html").read_text()
    assert 'id="emonav_drake.robot.lip.lip_step"' in page  # a function of robot/lip.py
    assert "One walking step of the LIP model" in page  # and its docstring


def test_the_configuration_page_lists_every_field_from_the_fields(built):
    _, site = built
    page = (site / "config" / "index.html").read_text()
    assert "emonav config --dump -->" not in page  # the hook replaced its marker
    # robot.step_time's doc, unit and range, read from its field
    assert "<td>T, one walking step</td>" in page and "<td>in [0.05, 2.0]</td>" in page
    assert 'id="walking"' in page  # a section's heading
