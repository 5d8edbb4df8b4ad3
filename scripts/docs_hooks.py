"""MkDocs hooks of the documentation site (`mkdocs.yml`, `hooks:`).

`docs/config.md` holds the marker `<!-- emonav config --dump -->`; on the site it becomes
the default configuration exactly as `emonav config --dump` prints it: every field with
its default value, unit and meaning, read from `params.py` when the site is built, so the
page cannot fall behind the code.
"""

from __future__ import annotations

MARKER = "<!-- emonav config --dump -->"


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Replace the marker by the annotated default configuration as a YAML block."""
    if MARKER not in markdown:
        return markdown
    from emonav_drake.config_notes import dump_annotated_yaml
    from emonav_drake.params import load_config

    block = "```yaml\n" + dump_annotated_yaml(load_config()).rstrip("\n") + "\n```\n"
    return markdown.replace(MARKER, block)
