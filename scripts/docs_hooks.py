"""MkDocs hooks of the documentation site (`mkdocs.yml`, `hooks:`).

`docs/config.md` holds the marker `<!-- emonav config --dump -->`; on the site it becomes
the reference of the default configuration: one table per section, every field with its
default value, unit, allowed range and meaning, read from the fields themselves
(`config_fields.setting`, the same metadata `emonav config --dump` prints as YAML
comments) when the site is built, so the page cannot fall behind the code.
"""

from __future__ import annotations

import json

MARKER = "<!-- emonav config --dump -->"


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Replace the marker by the reference of the default configuration."""
    if MARKER not in markdown:
        return markdown
    from emonav_drake.params import load_config

    return markdown.replace(MARKER, config_reference(load_config()))


def _cell(text: str) -> str:
    """`text` safe in a Markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def _default(value: object) -> str:
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    return f"`{_cell(json.dumps(value))}`"


def config_reference(obj: object) -> str:
    """The fields of configuration `obj` as Markdown: a heading and a table per section
    (nested dataclass), a table of its top-level fields first if it has any."""
    from emonav_drake.config_fields import reference_rows

    header = "| Field | Default | Unit | Allowed | Meaning |\n|---|---|---|---|---|\n"
    out: list[str] = []
    table: list[str] = []
    for row in reference_rows(obj):
        if row.is_section:
            if table:
                out.append(header + "".join(table))
                table = []
            out.append(f"### `{row.name}`\n\n{_cell(row.doc)}\n")
            continue
        name = row.name.rpartition(".")[2]
        table.append(
            f"| `{name}` | {_default(row.default)} | {_cell(row.unit)} | {_cell(row.range)} "
            f"| {_cell(row.doc)} |\n"
        )
    if table:
        out.append(header + "".join(table))
    return "\n".join(out)
