"""Typed configurations in YAML: loading, dumping and range checks for any dataclass.

The schema-agnostic half of the configuration: Drake's typed loader
(`pydrake.common.yaml.yaml_load_typed`, which already rejects unknown fields) preceded by a
check of the raw YAML against the dataclass (types, unknown fields, required fields), so
that every mistake raises `ConfigError` naming the dotted field; the dump back to YAML;
and the check of a dataclass's values against a table of allowed ranges. It knows no
particular configuration: `params.py` holds the project's (`EmoNavConfig`, its ranges,
`load_config`, `dump_config`), `learning/config.py` the training ones, `core/scenario.py`
the scenarios; all of them load and check through here.
"""

import dataclasses as dc
import math
import typing
from pathlib import Path
from typing import Any


class ConfigError(ValueError):
    """A configuration or scenario value is invalid; the message names the field."""


def require(ok: bool, field: str, value: Any, allowed: str) -> None:
    """Raise `ConfigError` "`field` = `value` is invalid: must be `allowed`" unless `ok`."""
    if not ok:
        raise ConfigError(f"{field} = {value!r} is invalid: must be {allowed}")


def _describe_range(lo: Any, hi: Any) -> str:
    if hi is None:
        return f">= {lo}"
    if lo is None:
        return f"<= {hi}"
    return f"in [{lo}, {hi}]"


def _validate_ranges(obj: Any, prefix: str, ranges: dict[str, Any]) -> None:
    """Check `obj`'s fields (recursively) against `ranges`.

    `ranges` maps a dotted field name to (low, high) inclusive — either bound may be None
    for "no bound" — or, for a list field, (length, low, high) for each element.
    """
    for f in dc.fields(obj):
        name = f"{prefix}{f.name}"
        value = getattr(obj, f.name)
        if dc.is_dataclass(value):
            _validate_ranges(value, name + ".", ranges)
            continue
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"{name} = {value!r} is invalid: must be a finite number")
        spec = ranges.get(name)
        if spec is None:
            continue
        if len(spec) == 3:
            length, lo, hi = spec
            if len(value) != length:
                raise ConfigError(f"{name} = {value!r} is invalid: must have {length} elements")
            for v in value:
                if not (math.isfinite(v) and lo <= v <= hi):
                    raise ConfigError(
                        f"{name} = {value!r} is out of range: each element in [{lo}, {hi}]"
                    )
        else:
            lo, hi = spec
            if (lo is not None and not lo <= value) or (hi is not None and not value <= hi):
                raise ConfigError(
                    f"{name} = {value!r} is out of range: allowed {_describe_range(lo, hi)}"
                )


def validate_ranges(obj: Any, ranges: dict[str, Any], prefix: str = "") -> None:
    """Public form of the range check (used by the training configurations)."""
    _validate_ranges(obj, prefix, ranges)


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
        raise ConfigError(f"{name} = {value!r} is invalid: expected {_TYPE_NAMES[kind]}")


def _check_yaml_value(name: str, value: Any, kind: Any) -> None:
    origin = typing.get_origin(kind)
    if dc.is_dataclass(kind):
        _check_yaml_mapping(kind, value, name)
    elif origin is list:
        (item,) = typing.get_args(kind)
        if not isinstance(value, list):
            raise ConfigError(f"{name} = {value!r} is invalid: expected a list")
        for i, v in enumerate(value):
            _check_yaml_value(f"{name}[{i}]", v, item)
    elif kind in _TYPE_NAMES:
        _check_scalar(name, value, kind)


def _check_yaml_mapping(schema: type, data: Any, prefix: str) -> None:
    """Types, unknown fields and required fields of raw YAML data against a dataclass."""
    what = prefix or schema.__name__
    if not isinstance(data, dict):
        raise ConfigError(
            f"{what} = {data!r} is invalid: expected a mapping of {schema.__name__} fields"
        )
    fields = {f.name: f for f in dc.fields(schema)}
    dot = f"{prefix}." if prefix else ""
    for key, value in data.items():
        if key not in fields:
            raise ConfigError(
                f"{dot}{key}: unknown field; {schema.__name__} has {', '.join(fields)}"
            )
        _check_yaml_value(f"{dot}{key}", value, fields[key].type)
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
            raise ConfigError(f"{path}: no such file")
        try:
            data = path.read_text()
        except UnicodeDecodeError:
            raise ConfigError(f"{path}: not a text (YAML) file") from None
    where = str(path) if path is not None else "<yaml>"
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


def dump_typed_yaml(obj: Any) -> str:
    """A dataclass as YAML text (loadable by `load_typed_yaml`)."""
    from pydrake.common.yaml import yaml_dump_typed

    return yaml_dump_typed(obj)
