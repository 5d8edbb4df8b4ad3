"""Typed configurations in YAML: loading, dumping and range checks for any dataclass.

The schema-agnostic half of the configuration: Drake's typed loader
(`pydrake.common.yaml.yaml_load_typed`, which already rejects unknown fields) preceded by a
check of the raw YAML against the dataclass (types, unknown fields, required fields), so
that every mistake raises `ConfigError` naming the dotted field; the dump back to YAML;
and the check of a dataclass's values against the ranges its fields declare
(`validate_fields`; the fields' doc, unit and range are `config_fields.setting`'s). It
knows no particular configuration: `params.py` holds the project's (`EmoNavConfig`,
`load_config`, `dump_config`), `learning/config.py` the training ones, `scenarios/scenario.py`
the scenarios; all of them load and check through here.

Every YAML text is checked before any loader builds it (`check_yaml_text`): at most
`MAX_YAML_BYTES`, at most `MAX_YAML_VALUES` values once its aliases are expanded (an
"alias bomb" of a few hundred bytes would otherwise expand to billions), and no key twice
in one mapping (YAML lets the last one win silently). Lists hold at most `MAX_LIST_ITEMS`
items unless the dataclass says otherwise (class attribute `_MAX_ITEMS`), checked on the
raw data before the typed load. Values quoted in messages are cut (`short_repr`).
"""

import dataclasses as dc
import math
import reprlib
import types
import typing
from pathlib import Path
from typing import Any

from emonav_drake.atomic_io import missing_file
from emonav_drake.errors import UserError

# A configuration, scenario or training configuration is a few kB; these bound what a
# hostile file can cost (parsing 100 000 values with Drake's pure-Python loader and its
# typed loader takes ~4 s).
MAX_YAML_BYTES = 1_000_000  # 1 MB
MAX_YAML_VALUES = 100_000  # scalars, lists and mappings, aliases expanded
MAX_LIST_ITEMS = 100  # items of a list field, unless its dataclass's `_MAX_ITEMS` says


class ConfigError(UserError, ValueError):
    """A configuration or scenario value is invalid; the message names the field."""


_SHORT = reprlib.Repr()
_SHORT.maxlevel = 3
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxset = 12
_SHORT.maxdict = 8
_SHORT.maxstring = 80
_SHORT.maxlong = 40
_SHORT.maxother = 80


def short_repr(value: Any) -> str:
    """`repr(value)` for a message, cut to about 100 characters; bounded in time too
    (nested lists are not walked beyond a few levels and a dozen items)."""
    return _SHORT.repr(value)


def require(ok: bool, field: str, value: Any, allowed: str) -> None:
    """Raise `ConfigError` "`field` = `value` is invalid: must be `allowed`" unless `ok`."""
    if not ok:
        raise ConfigError(f"{field} = {short_repr(value)} is invalid: must be {allowed}")


def _describe_range(lo: Any, hi: Any) -> str:
    if hi is None:
        return f">= {lo}"
    if lo is None:
        return f"<= {hi}"
    return f"in [{lo}, {hi}]"


def validate_fields(obj: Any, prefix: str = "") -> None:
    """Check every field of dataclass `obj` against the range in its metadata
    (`config_fields.setting`); raise `ConfigError` "`prefix``field` = value is out of
    range: …" for the first outside.

    Recurses into nested dataclasses, a union field's dataclass value included (a
    planner spec), with the field's dotted name as their prefix. A range is (low, high)
    inclusive (None: no bound), or (length, low, high) for a list field's elements (of
    each row, for a list of lists; length None: any length). A non-finite float is
    refused in any field; an unset optional field (None) is not checked.
    """
    for f in dc.fields(obj):
        name = f"{prefix}{f.name}"
        value = getattr(obj, f.name)
        if dc.is_dataclass(value):
            validate_fields(value, name + ".")
            continue
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"{name} = {value!r} is invalid: must be a finite number")
        spec = f.metadata.get("range")
        if spec is None or value is None:
            continue
        if len(spec) == 3:
            length, lo, hi = spec
            if length is not None and len(value) != length:
                raise ConfigError(
                    f"{name} = {short_repr(value)} is invalid: must have {length} elements"
                )
            for v in _flat(value):
                if not (math.isfinite(v) and lo <= v <= hi):
                    raise ConfigError(
                        f"{name} = {short_repr(value)} is out of range: each element in "
                        f"[{lo}, {hi}]"
                    )
        else:
            lo, hi = spec
            if (lo is not None and not lo <= value) or (hi is not None and not value <= hi):
                raise ConfigError(
                    f"{name} = {short_repr(value)} is out of range: allowed "
                    f"{_describe_range(lo, hi)}"
                )


def _flat(values: list) -> list:
    """The numbers of a list, or of a list of lists (a matrix's rows)."""
    return [x for v in values for x in (_flat(v) if isinstance(v, list) else [v])]


def required_fields(schema: type) -> tuple[str, ...]:
    """Fields a YAML mapping for `schema` must give (class attribute `_REQUIRED`)."""
    return tuple(getattr(schema, "_REQUIRED", ()))


_TYPE_NAMES = {float: "a number", int: "an integer", bool: "true or false", str: "a string"}


def _check_scalar(name: str, value: Any, kind: type) -> None:
    """Mirror Drake's primitive conversions; raise `ConfigError` naming the field."""
    ok = False
    if kind is bool:
        ok = isinstance(value, bool) or value in ("true", "false")
    elif kind is str:
        ok = isinstance(value, str)
    elif kind in (int, float) and not isinstance(value, bool):
        if isinstance(value, int):
            ok = True
        elif isinstance(value, float):
            ok = kind is float or value.is_integer()
        elif isinstance(value, str):
            try:
                kind(value)
                ok = True
            except ValueError:
                ok = False
    if not ok:
        raise ConfigError(f"{name} = {short_repr(value)} is invalid: expected {_TYPE_NAMES[kind]}")


def _union_member(name: str, value: dict, kinds: tuple) -> Any:
    """The dataclass of a `Union` field that a YAML mapping names by its tag (`!Name {...}`;
    untagged: the first), or `ConfigError` listing the tags."""
    tag = value.get("_tag")
    if tag is None:
        return kinds[0]
    for kind in kinds:
        if tag == f"!{kind.__name__}":
            return kind
    tags = ", ".join(f"!{k.__name__}" for k in kinds)
    raise ConfigError(f"{name}: unknown tag {short_repr(tag)}; choose one of {tags}")


def _check_yaml_value(name: str, value: Any, kind: Any, max_items: int = MAX_LIST_ITEMS) -> None:
    origin = typing.get_origin(kind)
    if origin in (typing.Union, types.UnionType) and all(
        dc.is_dataclass(k) for k in typing.get_args(kind)
    ):
        kinds = typing.get_args(kind)
        if not isinstance(value, dict):
            tags = ", ".join(f"!{k.__name__}" for k in kinds)
            raise ConfigError(
                f"{name} = {short_repr(value)} is invalid: expected a mapping tagged with one "
                f"of {tags}, e.g. `{name.rpartition('.')[2]}: !{kinds[0].__name__} {{}}`"
            )
        member = _union_member(name, value, kinds)
        fields = {k: v for k, v in value.items() if k != "_tag"}
        _check_yaml_mapping(member, fields, name)
    elif dc.is_dataclass(kind):
        _check_yaml_mapping(kind, value, name)
    elif origin is list:
        (item,) = typing.get_args(kind)
        if not isinstance(value, list):
            raise ConfigError(f"{name} = {short_repr(value)} is invalid: expected a list")
        if len(value) > max_items:
            raise ConfigError(f"{name}: {len(value)} given, at most {max_items} allowed")
        for i, v in enumerate(value):
            _check_yaml_value(f"{name}[{i}]", v, item)
    elif kind in _TYPE_NAMES:
        _check_scalar(name, value, kind)


def _check_yaml_mapping(schema: type, data: Any, prefix: str) -> None:
    """Types, unknown fields and required fields of raw YAML data against a dataclass."""
    what = prefix or schema.__name__
    if not isinstance(data, dict):
        raise ConfigError(
            f"{what} = {short_repr(data)} is invalid: expected a mapping of "
            f"{schema.__name__} fields"
        )
    fields = {f.name: f for f in dc.fields(schema)}
    max_items = getattr(schema, "_MAX_ITEMS", {})
    dot = f"{prefix}." if prefix else ""
    moved = getattr(schema, "_MOVED", {})
    for key, value in data.items():
        if key in moved and key not in fields:
            raise ConfigError(f"{dot}{key}: no longer a field: {moved[key]}")
        if key not in fields:
            name = key if isinstance(key, str) and len(key) <= 80 else short_repr(key)
            raise ConfigError(
                f"{dot}{name}: unknown field; {schema.__name__} has {', '.join(fields)}"
            )
        limit = max_items.get(key, MAX_LIST_ITEMS)
        hint = getattr(schema, "_HINTS", {}).get(key)  # for a scalar where a mapping goes
        try:
            _check_yaml_value(f"{dot}{key}", value, fields[key].type, limit)
        except ConfigError as e:
            if hint is None or isinstance(value, dict):
                raise
            raise ConfigError(f"{e}; {hint}") from None
    missing = [k for k in required_fields(schema) if k not in data]
    if missing:
        raise ConfigError(
            f"{dot}{missing[0]}: required field missing ({schema.__name__} needs "
            f"{', '.join(required_fields(schema))})"
        )


def _yaml_error_line(e: Exception) -> str:
    mark = getattr(e, "problem_mark", None)
    problem = getattr(e, "problem", None) or str(e).splitlines()[0]
    if mark is not None:
        return f"invalid YAML at line {mark.line + 1}, column {mark.column + 1}: {problem}"
    return f"invalid YAML: {problem}"


def _yaml_events(text: str) -> Any:
    """The parser's events of `text` (libyaml's parser when PyYAML has it): nothing built."""
    import yaml

    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    return yaml.parse(text, Loader=loader)


class _Collection:
    """A mapping or sequence being read by `check_yaml_text`."""

    def __init__(self, path: str, is_mapping: bool, anchor: str | None, start: int) -> None:
        self.path = path
        self.is_mapping = is_mapping
        self.anchor = anchor
        self.start = start  # values counted before it
        self.keys: dict[str, int] = {}  # mapping: key → its line
        self.at_key = True  # mapping: the next node is a key
        self.key: str | None = None  # mapping: the key whose value comes next
        self.index = 0  # sequence: the next item's index

    def child_path(self) -> str:
        if not self.is_mapping:
            return f"{self.path}[{self.index}]"
        key = self.key if self.key is not None else "?"
        return f"{self.path}.{key}" if self.path else key


def check_yaml_text(where: str, text: str) -> None:
    """Refuse (`ConfigError` naming `where`) a YAML text that is too large, expands to too
    many values through its aliases, or gives a key twice in one mapping.

    Reads the parser's events only, so nothing is expanded or built: an alias adds the
    size of the node it names, and the count stops at `MAX_YAML_VALUES`. A syntax error is
    left to the loader, which reports it with its position. Merge keys (`<<`) are not
    duplicates (the mapping's own keys override the merged ones).
    """
    import yaml

    if len(text) > MAX_YAML_BYTES:
        raise ConfigError(_too_large(where, len(text.encode())))
    count = 0  # values so far, aliases expanded
    aliased = False
    sizes: dict[str, int] = {}  # anchor → values of its node
    stack: list[_Collection] = []
    try:
        for ev in _yaml_events(text):
            if isinstance(ev, yaml.CollectionEndEvent):
                done = stack.pop()
                if done.anchor is not None:
                    sizes[done.anchor] = count - done.start
                continue
            if not isinstance(ev, yaml.NodeEvent):
                continue
            _refuse_python_tag(where, ev)
            parent = stack[-1] if stack else None
            path = parent.child_path() if parent is not None else ""
            if parent is not None and parent.is_mapping:
                if parent.at_key:
                    path = _check_key(where, parent, ev)
                parent.at_key = not parent.at_key
            elif parent is not None:
                parent.index += 1
            if isinstance(ev, yaml.AliasEvent):
                if ev.anchor not in sizes:  # undefined, or inside its own node
                    if any(c.anchor == ev.anchor for c in stack):
                        raise ConfigError(
                            f"{where}: line {ev.start_mark.line + 1}: alias *{ev.anchor} "
                            "refers to a node that contains it (a recursive alias)"
                        )
                    return  # undefined: the loader says so
                count += sizes[ev.anchor]
                aliased = True
            else:
                count += 1
                if isinstance(ev, yaml.CollectionStartEvent):
                    is_mapping = isinstance(ev, yaml.MappingStartEvent)
                    stack.append(_Collection(path, is_mapping, ev.anchor, count - 1))
                elif ev.anchor is not None:
                    sizes[ev.anchor] = 1
            if count > MAX_YAML_VALUES:
                raise ConfigError(_too_many(where, aliased))
    except yaml.YAMLError:
        return  # the loader reports it, with its line and column


# What `!!python/…` expands to (PyYAML's tags that build Python objects or call code).
_PYTHON_TAG = "tag:yaml.org,2002:python/"


def _refuse_python_tag(where: str, ev: Any) -> None:
    """A `!!python/…` tag is refused by name (nothing here would build it, but the
    loader's "expected a mapping node" said nothing of why)."""
    tag = getattr(ev, "tag", None) or ""
    if tag.startswith(_PYTHON_TAG) or tag.startswith("!python/"):
        shown = "!!python/" + tag[len(_PYTHON_TAG) :] if tag.startswith(_PYTHON_TAG) else tag
        raise ConfigError(
            f"{where}: line {ev.start_mark.line + 1}: the Python tag {shown} is refused: "
            "these YAML files hold data only (numbers, strings, lists, mappings and the "
            "planner spec tags such as !MpcSpec)"
        )


def _check_key(where: str, mapping: _Collection, ev: Any) -> str:
    """Record a key of `mapping` (a scalar event); refuse it if given before."""
    import yaml

    if not isinstance(ev, yaml.ScalarEvent) or (ev.value == "<<" and not ev.style):
        mapping.key = None
        return mapping.child_path()
    line = ev.start_mark.line + 1
    first = mapping.keys.get(ev.value)
    if first is not None:
        inside = f" in {mapping.path}" if mapping.path else ""
        raise ConfigError(
            f"{where}: line {line}: key {short_repr(ev.value)}{inside} is given twice (first "
            f"at line {first}): YAML would silently keep the last one; remove one"
        )
    mapping.keys[ev.value] = line
    mapping.key = ev.value
    return mapping.child_path()


def _too_large(where: str, size: int) -> str:
    return (
        f"{where}: {size} bytes; a configuration, scenario or training file is at most "
        f"1 MB ({MAX_YAML_BYTES} bytes) here"
    )


def _too_many(where: str, aliased: bool) -> str:
    how = " once its aliases are expanded (an alias bomb?)" if aliased else ""
    return (
        f"{where}: more than {MAX_YAML_VALUES} values{how}; a configuration, scenario or "
        "training file holds far fewer: refused before loading"
    )


def load_typed_yaml_raw(
    schema: type, path: str | Path | None = None, data: str | None = None, defaults: Any = None
) -> tuple[Any, dict]:
    """`load_typed_yaml` that also returns the raw mapping (to see which fields were given)."""
    from pydrake.common.yaml import yaml_load_data, yaml_load_typed

    if (path is None) == (data is None):
        raise ValueError("give exactly one of path or data")
    if path is not None:
        path = Path(path)
        if path.is_dir():
            raise ConfigError(f"{path}: is a directory, expected a YAML file")
        if not path.is_file():
            raise ConfigError(f"{path}: {missing_file(path)}")
        size = path.stat().st_size
        if size > MAX_YAML_BYTES:  # refused before it is read
            raise ConfigError(_too_large(str(path), size))
        try:
            data = path.read_text()
        except UnicodeDecodeError:
            raise ConfigError(f"{path}: not a text (YAML) file") from None
    where = str(path) if path is not None else "<yaml>"
    check_yaml_text(where, data)
    try:
        raw = yaml_load_data(data)
    except Exception as e:  # yaml syntax errors come from the yaml parser
        raise ConfigError(f"{where}: {_yaml_error_line(e)}") from None
    if raw is None:
        raise ConfigError(
            f"{where}: the file is empty; expected a YAML mapping of {schema.__name__} fields"
        )
    try:
        _check_yaml_mapping(schema, raw, "")
    except ConfigError as e:
        raise ConfigError(f"{where}: {e}") from None
    try:
        obj = yaml_load_typed(
            schema=schema, data=data, defaults=defaults if defaults is not None else schema()
        )
    except (RuntimeError, TypeError, ValueError) as e:
        raise ConfigError(f"{where}: {e}") from None
    except Exception as e:
        raise ConfigError(f"{where}: not valid YAML for {schema.__name__}: {e}") from None
    return obj, raw


def load_typed_yaml(
    schema: type, path: str | Path | None = None, data: str | None = None, defaults: Any = None
) -> Any:
    """Load a dataclass from YAML with Drake's typed loader, re-raising as `ConfigError`.

    Exactly one of `path` or `data` is given. Fields absent from the YAML keep `defaults`,
    except the schema's required fields (`_REQUIRED`). Before Drake's loader runs, the raw
    data is checked against the schema so that an empty file, an unknown field, a wrong
    type or a missing required field is reported with the dotted field name.
    """
    return load_typed_yaml_raw(schema, path=path, data=data, defaults=defaults)[0]


def to_plain(obj: Any) -> dict:
    """A dataclass as plain data (dicts, lists, scalars) for a saved state or a record: as
    `dataclasses.asdict`, but a `Union` field's value keeps its class as `_tag` (as in
    YAML), so `from_plain` restores the same object."""
    from pydrake.common.yaml import yaml_load_data

    return yaml_load_data(dump_typed_yaml(obj))


def from_plain(schema: type, data: dict) -> Any:
    """The dataclass `schema` from `to_plain`'s data (`ConfigError` naming the field of
    anything wrong, as `load_typed_yaml`)."""
    from pydrake.common.yaml import yaml_dump

    return load_typed_yaml(schema, data=yaml_dump(data))


def dump_typed_yaml(obj: Any) -> str:
    """A dataclass as YAML text (loadable by `load_typed_yaml`)."""
    from pydrake.common.yaml import yaml_dump_typed

    return yaml_dump_typed(obj)
