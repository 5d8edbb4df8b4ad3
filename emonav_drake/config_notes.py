"""Field notes of configuration dataclasses, read from their source, and the annotated dump.

A field's note is the comment written next to it in the dataclass's source: the trailing
`# comment` of its line (`step_time: float = 0.4  # T, one walking step [s]`), else the
comment line(s) immediately above it. A dataclass is described by the first line of its
docstring. `dump_annotated_yaml` writes a dataclass as the YAML of `dump_typed_yaml` with
each field's note as a trailing comment and each nested dataclass headed by its
description; comments do not change what the YAML loads to.
"""

import ast
import dataclasses as dc
import functools
import inspect
import io
import re
import textwrap
import tokenize
from typing import Any

from emonav_drake.config_yaml import dump_typed_yaml

# A block-mapping line of the dump: indentation, key, and the value (empty for a mapping).
_KEY_LINE = re.compile(r"^( *)([A-Za-z_][A-Za-z0-9_]*):(?: (.*))?$")


def describe(cls: type) -> str:
    """The first line of `cls`'s docstring ("" if it has none)."""
    doc = (cls.__dict__.get("__doc__") or "").strip()
    # `dataclass` gives an undocumented class its signature, "Name(field: type, …)", as doc
    if not doc or (dc.is_dataclass(cls) and doc.startswith(f"{cls.__name__}(")):
        return ""
    return doc.splitlines()[0].strip()


def _comments(source: str) -> tuple[dict[int, str], set[int]]:
    """Comment text by line number, and the lines holding only a comment."""
    comments: dict[int, str] = {}
    code_lines: set[int] = set()
    skip = (tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER)
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            comments[tok.start[0]] = tok.string.lstrip("#").strip()
        elif tok.type not in skip:
            code_lines.update(range(tok.start[0], tok.end[0] + 1))
    return comments, {line for line in comments if line not in code_lines}


def _own_field_notes(cls: type) -> dict[str, str]:
    """Notes of the fields annotated in `cls`'s own body (not its bases)."""
    try:
        source = textwrap.dedent(inspect.getsource(cls))
    except (OSError, TypeError):  # no source (built in a REPL, frozen): no notes
        return {}
    comments, standalone = _comments(source)
    (node,) = ast.parse(source).body
    notes: dict[str, str] = {}
    for item in getattr(node, "body", []):
        if not (isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name)):
            continue
        end = item.end_lineno or item.lineno
        trailing = [
            comments[n]
            for n in range(item.lineno, end + 1)
            if n in comments and n not in standalone
        ]
        above: list[str] = []
        line = item.lineno - 1
        while line in standalone:
            above.insert(0, comments[line])
            line -= 1
        note = trailing[0] if trailing else " ".join(t for t in above if t)
        if note:
            notes[item.target.id] = note
    return notes


@functools.cache
def field_notes(cls: type) -> dict[str, str]:
    """Each field of dataclass `cls` that has a note in the source → that note.

    The trailing comment of the field's line(s), else the comment line(s) immediately
    above it, without the `#`. Fields inherited from dataclass bases keep their notes,
    unless the subclass redefines them.
    """
    notes: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if dc.is_dataclass(klass):
            notes.update(_own_field_notes(klass))
    names = {f.name for f in dc.fields(cls)}
    return {k: v for k, v in notes.items() if k in names}


def _dataclass_type(kind: Any) -> type | None:
    return kind if isinstance(kind, type) and dc.is_dataclass(kind) else None


def undocumented_fields(cls: type, prefix: str = "") -> list[str]:
    """Dotted names of the fields of `cls` (recursively) with no note.

    A nested dataclass field counts as documented by its own note or by its type's
    docstring; its fields are checked in turn.
    """
    notes = field_notes(cls)
    missing: list[str] = []
    for f in dc.fields(cls):
        nested = _dataclass_type(f.type)
        if f.name not in notes and not (nested and describe(nested)):
            missing.append(prefix + f.name)
        if nested:
            missing += undocumented_fields(nested, f"{prefix}{f.name}.")
    return missing


def annotate_yaml(schema: type, text: str) -> str:
    """`text`, a block-style YAML dump of a `schema` dataclass, with comments added.

    Each `key: value` line of a dataclass field gets the field's note as a trailing
    comment; each nested dataclass's `key:` line is preceded by a blank line and a comment
    with the first line of its docstring. Lines it cannot attribute to a field (list
    items, continuation lines of a long scalar) are left as they are.
    """
    lines = text.splitlines()
    out: list[str] = []
    levels: list[tuple[int, type]] = []  # (indentation, dataclass whose keys sit there)
    pending: tuple[int, type] | None = (-1, schema)  # a mapping opened, indentation unknown
    for i, line in enumerate(lines):
        m = _KEY_LINE.match(line)
        if m is None:
            out.append(line)
            continue
        indent, key, value = len(m[1]), m[2], (m[3] or "").strip()
        if pending is not None and indent > pending[0]:
            levels.append((indent, pending[1]))
        pending = None
        while levels and levels[-1][0] > indent:
            levels.pop()
        field = None
        if levels and levels[-1][0] == indent:
            field = {f.name: f for f in dc.fields(levels[-1][1])}.get(key)
        if field is None:
            out.append(line)
            continue
        note = field_notes(levels[-1][1]).get(key, "")
        nested = _dataclass_type(field.type)
        if nested is not None and not value:
            pending = (indent, nested)
            if describe(nested):
                if out and out[-1].strip():
                    out.append("")
                out.append(f"{m[1]}# {describe(nested)}")
        else:
            nxt = lines[i + 1] if i + 1 < len(lines) else ""
            continued = nxt.strip() and len(nxt) - len(nxt.lstrip(" ")) > indent
            if continued and not _KEY_LINE.match(nxt):
                note = ""  # a scalar continued on the next line: a comment would cut it
        out.append(f"{line}  # {note}" if note else line)
    return "\n".join(out) + ("\n" if text.endswith("\n") else "")


def dump_annotated_yaml(obj: Any) -> str:
    """Dataclass `obj` as YAML (`dump_typed_yaml`), annotated by `annotate_yaml`.

    Starts with a comment line describing `obj`'s class. Loads back to the same data as
    the bare dump: only comments and blank lines are added.
    """
    head = describe(type(obj))
    body = annotate_yaml(type(obj), dump_typed_yaml(obj))
    return f"# {head}\n\n{body}" if head else body
