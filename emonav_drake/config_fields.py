"""Configuration fields that describe themselves: each field's doc, unit and allowed range.

Every configuration dataclass (the project's `EmoNavConfig` and its sections, the training
configurations, the scenario, the emotion estimate, the planner specs) declares its fields
with `setting`, so that one line says all there is to know of a field:

    step_time: float = setting(0.4, "T, one walking step", "s", (0.05, 2.0))

`setting` is `dataclasses.field` with the doc, unit and range as the field's metadata,
which Drake's typed YAML loader ignores. They are read by `typed_yaml.validate_fields`
(every value against its range), by the annotated dump (`dump_annotated_yaml`, `emonav
config --dump`: each field's doc, unit and range as a trailing YAML comment) and by the
configuration reference of the documentation (`reference_rows`, `scripts/docs_hooks.py`).

A range is (low, high), inclusive, None for no bound; or, for a list field, (length, low,
high) for each of its elements (of each row, for a list of lists; length None: any
number of them; both bounds given). Ranges that several configurations share are named
here (`SEED_RANGE`, `WORLD_POINT`) or read from the field that owns them (`field_range`),
so that a scenario file and a configuration are held to one range. Cross-field rules (a
minimum below its maximum, a rate that divides another) are code, in each dataclass's
`validate`.
"""

import copy
import dataclasses as dc
import re
import types
import typing
from collections.abc import Iterator
from typing import Any

from emonav_drake.typed_yaml import dump_typed_yaml

# Seeds are 64-bit unsigned integers (numpy's generators take them; a larger one would
# alias a smaller one).
SEED_RANGE = (0, 2**64 - 1)
# A point [x, y] of the world [m]: the robot's start and goal, a scenario's points.
WORLD_POINT = (2, -50.0, 50.0)


def setting(
    default: Any = dc.MISSING,
    doc: str = "",
    unit: str = "",
    bounds: tuple | None = None,
    *,
    factory: Any = None,
) -> Any:
    """A dataclass field with its `doc`, `unit` ("" for counts, flags and names) and
    allowed range `bounds` (see the module's docstring) as metadata.

    Give `default` or `factory` (as `dataclasses.field`'s `default_factory`). A list
    default is copied for each instance (a fresh list each time, as a factory would
    give). A nested dataclass given as `factory` is documented by the first line of its
    docstring unless `doc` says otherwise.
    """
    if (default is dc.MISSING) == (factory is None):
        raise TypeError("setting: give exactly one of a default or a factory")
    if isinstance(default, list):
        factory, default = (lambda value=default: copy.deepcopy(value)), dc.MISSING
    if not doc and isinstance(factory, type) and dc.is_dataclass(factory):
        doc = describe(factory)
    if bounds is not None:
        bounds = _checked_bounds(tuple(bounds))
    metadata = {"doc": doc, "unit": unit, "range": bounds}
    if factory is not None:
        return dc.field(default_factory=factory, metadata=metadata)
    return dc.field(default=default, metadata=metadata)


def _checked_bounds(bounds: tuple) -> tuple:
    """`bounds` if it is a range of a form `validate_fields` reads, else `ValueError`:
    (low, high), either may be None, or (length, low, high), both bounds given."""
    ok = len(bounds) in (2, 3)
    if ok and len(bounds) == 3:
        length, lo, hi = bounds
        ok = (length is None or isinstance(length, int)) and None not in (lo, hi)
    if ok:
        lo, hi = bounds[-2:]
        ok = lo is None or hi is None or lo <= hi
    if not ok:
        raise ValueError(f"setting: {bounds!r} is not (low, high) nor (length, low, high)")
    return bounds


def describe(cls: type) -> str:
    """The first line of `cls`'s docstring ("" if it has none)."""
    doc = (cls.__dict__.get("__doc__") or "").strip()
    # `dataclass` gives an undocumented class its signature, "Name(field: type, …)", as doc
    if not doc or (dc.is_dataclass(cls) and doc.startswith(f"{cls.__name__}(")):
        return ""
    return doc.splitlines()[0].strip()


def _dataclass_types(kind: Any) -> tuple[type, ...]:
    """The dataclass a field holds: its type, or each member of a union of dataclasses."""
    if isinstance(kind, type) and dc.is_dataclass(kind):
        return (kind,)
    if typing.get_origin(kind) in (typing.Union, types.UnionType):
        members = typing.get_args(kind)
        if all(isinstance(k, type) and dc.is_dataclass(k) for k in members):
            return members
    return ()


def field_of(cls: type, name: str) -> dc.Field:
    """The field `name` of dataclass `cls`; a dotted name follows nested dataclass fields
    (`field_of(EmoNavConfig, "robot.start")`). `KeyError` if there is none."""
    head, _, rest = name.partition(".")
    fields = {f.name: f for f in dc.fields(cls)}
    if head not in fields:
        raise KeyError(f"{cls.__name__} has no field {head!r}")
    if not rest:
        return fields[head]
    nested = _dataclass_types(fields[head].type)
    if len(nested) != 1:
        raise KeyError(f"{cls.__name__}.{head} is not a dataclass section")
    return field_of(nested[0], rest)


def field_range(cls: type, name: str) -> tuple | None:
    """The allowed range of `cls`'s field `name` (dotted for a nested one); None if it
    has none."""
    return field_of(cls, name).metadata.get("range")


def field_doc(cls: type, name: str) -> str:
    """The doc of `cls`'s field `name` (dotted for a nested one); "" if it has none."""
    return field_of(cls, name).metadata.get("doc", "")


def field_unit(cls: type, name: str) -> str:
    """The unit of `cls`'s field `name` (dotted for a nested one); "" if it has none."""
    return field_of(cls, name).metadata.get("unit", "")


def undocumented_fields(cls: type, prefix: str = "") -> list[str]:
    """Dotted names of the fields of `cls` (its nested dataclasses' too) with no doc."""
    missing: list[str] = []
    for f in dc.fields(cls):
        if not f.metadata.get("doc"):
            missing.append(prefix + f.name)
        nested = _dataclass_types(f.type)
        if len(nested) == 1:
            missing += undocumented_fields(nested[0], f"{prefix}{f.name}.")
    return missing


def _number(x: Any) -> str:
    """A bound as written in a note: as in the code, a float to 6 digits if longer (π/2),
    a huge integer as a power of two if it is one, or one less (2**64 - 1)."""
    if isinstance(x, int) and x >= 2**32 and (x & (x + 1) == 0 or x & (x - 1) == 0):
        return f"2**{x.bit_length()} - 1" if x & (x + 1) == 0 else f"2**{x.bit_length() - 1}"
    text = repr(x)
    return f"{x:.6g}" if isinstance(x, float) and len(text) > 8 else text


def range_text(bounds: tuple | None) -> str:
    """A range in words: "in [0.05, 2.0]", ">= 1", "2 values, each in [-50.0, 50.0]"."""
    if bounds is None:
        return ""
    if len(bounds) == 3:
        length, lo, hi = bounds
        each = f"each in [{_number(lo)}, {_number(hi)}]"
        return each if length is None else f"{length} values, {each}"
    lo, hi = bounds
    if hi is None:
        return f">= {_number(lo)}"
    if lo is None:
        return f"<= {_number(hi)}"
    return f"in [{_number(lo)}, {_number(hi)}]"


def field_note(f: dc.Field) -> str:
    """A field's doc, unit and range in one line: "T, one walking step [s]; in [0.05, 2.0]"."""
    note = f.metadata.get("doc", "")
    if f.metadata.get("unit"):
        note += f" [{f.metadata['unit']}]"
    bounds = range_text(f.metadata.get("range"))
    return f"{note}; {bounds}" if note and bounds else note or bounds


@dc.dataclass(frozen=True)
class ReferenceRow:
    """One field of a configuration in its reference (`reference_rows`)."""

    name: str  # dotted
    default: Any  # None for a section
    unit: str
    range: str  # `range_text`
    doc: str
    is_section: bool = False  # a nested dataclass: its fields follow


def reference_rows(obj: Any, prefix: str = "") -> Iterator[ReferenceRow]:
    """The fields of dataclass `obj` with their values, units, ranges and docs; a nested
    dataclass's row (`is_section`) is followed by its fields' rows. The configuration
    reference of the documentation (`scripts/docs_hooks.py`)."""
    for f in dc.fields(obj):
        value, meta, name = getattr(obj, f.name), f.metadata, prefix + f.name
        doc = meta.get("doc", "")
        if dc.is_dataclass(value) and len(_dataclass_types(f.type)) == 1:
            yield ReferenceRow(name, None, "", "", doc, is_section=True)
            yield from reference_rows(value, name + ".")
        else:
            bounds = range_text(meta.get("range"))
            yield ReferenceRow(name, value, meta.get("unit", ""), bounds, doc)


# A block-mapping line of the dump: indentation, key, and the value (empty for a mapping).
_KEY_LINE = re.compile(r"^( *)([A-Za-z_][A-Za-z0-9_]*):(?: (.*))?$")


def _opened(field: dc.Field, value: str) -> type | None:
    """The dataclass whose mapping a `key: value` line of `field` opens: a nested
    dataclass (no value), or a union member named by its tag (`!MpcSpec`, or no value
    for the first member); None for a line that holds the value itself."""
    members = _dataclass_types(field.type)
    if not members:
        return None
    if not value:
        return members[0]
    for kind in members:
        if value == f"!{kind.__name__}":
            return kind
    return None


def annotate_yaml(schema: type, text: str) -> str:
    """`text`, a block-style YAML dump of a `schema` dataclass, with comments added.

    Each `key: value` line of a dataclass field gets the field's `field_note` as a
    trailing comment; each nested dataclass's `key:` line is preceded by a blank line and
    a comment with its doc. Lines it cannot attribute to a field (list items,
    continuation lines of a long scalar) are left as they are.
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
        note = field_note(field)
        nested = _opened(field, value)
        if nested is not None and not _dataclass_types(field.type)[1:]:
            pending = (indent, nested)
            if out and out[-1].strip():
                out.append("")
            if field.metadata.get("doc"):
                out.append(f"{m[1]}# {field.metadata['doc']}")
            note = ""
        elif nested is not None:  # a union's member: its doc stays on the line
            pending = (indent, nested)
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
