"""One field of a section: its declaration (kind, unit, shape, check, documentation line, C++ target),
its parsing from TOML into SI and its TOML form.

A section declares each field once, as ``name: type = field(metadata=quantity("length", "what it is",
check=POSITIVE))``; the parser, the saved config.toml and docs/configuration.md read the declaration.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from .quantities import KINDS, UREG, ConfigError, describe, parse_units, same_kind

#: A predicate on the SI value with its description ("> 0").
Check = tuple[Callable[[Any], bool], str]


@dataclass(frozen=True)
class Spec:
    """How one field is written in TOML, checked and documented.

    doc: one line on what the field is; unit: SI unit string of a quantity ("" for a dimensionless
    number), None for a string option, an integer or a boolean; quantity: its kind in messages; shape:
    () for a scalar, a leading -1 for any number n >= 1 of rows (``(-1, 3)``: n x 3);
    check: a predicate on the SI value with its description; choices: the values of an
    option (None: any non-empty string); cpp: the C++ setting it sets, for [navigation] the member of
    ``nav::NavigationSettings`` ("camera.min_range"), for [physical] the member of
    ``dynamics::PhysicalSettings`` ("mass"; "plates[].area": that member of each plate), None when no
    setting or a derived one takes it.
    """

    doc: str
    unit: str | None = ""
    quantity: str = "dimensionless"
    shape: tuple[int, ...] = ()
    check: Check | None = None
    choices: tuple[str, ...] | None = None
    integer: bool = False
    boolean: bool = False
    cpp: str | None = None


def quantity(
    kind: str, doc: str, shape: tuple[int, ...] = (), check: Check | None = None, cpp: str | None = None
) -> dict[str, Spec]:
    """Field metadata of a quantity of a kind of :data:`KINDS` (its SI unit)."""
    return {"spec": Spec(doc, KINDS[kind], kind, shape, check, cpp=cpp)}


def number(doc: str, shape: tuple[int, ...] = (), check: Check | None = None, cpp: str | None = None) -> dict[str, Spec]:
    """Field metadata of a dimensionless number or array."""
    return {"spec": Spec(doc, "", "dimensionless", shape, check, cpp=cpp)}


def integer(doc: str, check: Check | None = None, cpp: str | None = None) -> dict[str, Spec]:
    """Field metadata of an integer."""
    return {"spec": Spec(doc, None, "integer", (), check, integer=True, cpp=cpp)}


def boolean(doc: str, cpp: str | None = None) -> dict[str, Spec]:
    """Field metadata of a boolean (true or false)."""
    return {"spec": Spec(doc, None, "boolean", boolean=True, cpp=cpp)}


def option(doc: str, *choices: str) -> dict[str, Spec]:
    """Field metadata of a string option (any non-empty string if no choices)."""
    return {"spec": Spec(doc, None, "option", (), None, choices or None)}


POSITIVE: Check = (lambda v: bool(np.all(np.asarray(v) > 0.0)), "> 0")
NONNEGATIVE: Check = (lambda v: bool(np.all(np.asarray(v) >= 0.0)), ">= 0")
UNIT_INTERVAL: Check = (lambda v: 0.0 < v < 1.0, "in (0, 1)")
HALF_TURN: Check = (lambda v: 0.0 < v < math.pi, "in (0, 180) deg")
AT_LEAST_ONE: Check = (lambda v: v >= 1, ">= 1")
NONZERO: Check = (lambda v: float(np.linalg.norm(v)) > 0.0, "non-zero")


def spec_of(cls: type, name: str) -> Spec:
    """The declaration of the field ``name`` of the section class ``cls``."""
    for f in fields(cls):
        if f.name == name:
            spec: Spec = f.metadata["spec"]
            return spec
    raise KeyError(name)


def is_si(spec: Spec, value: Any) -> bool:
    """Whether ``value`` of a quantity field is an SI number or array (not a text or table with a unit)."""
    return bool(spec.unit) and not isinstance(value, (str, Mapping))


def encode(spec: Spec, value: Any) -> Any:
    """SI value -> its TOML form."""
    if spec.unit is None:
        return value
    if spec.shape == ():
        v = float(value)
        return f"{v!r} {spec.unit}" if spec.unit else v
    lst = np.asarray(value, dtype=np.float64).tolist()
    return {"value": lst, "unit": spec.unit} if spec.unit else lst


def parse_field(spec: Spec, raw: Any, where: str) -> Any:
    """The SI value of a field written ``raw`` in TOML; ``where`` (file: section.field) names it in errors."""
    if spec.boolean:
        if not isinstance(raw, bool):
            raise ConfigError(f"{where}: expected true or false, got {raw!r}")
        return raw
    if spec.choices is not None or (spec.unit is None and not spec.integer):
        if not isinstance(raw, str) or not raw:
            raise ConfigError(f"{where}: expected a non-empty string, got {raw!r}")
        if spec.choices is not None and raw not in spec.choices:
            raise ConfigError(f"{where}: expected one of {list(spec.choices)}, got {raw!r}")
        return raw
    if spec.integer:
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise ConfigError(f"{where}: expected an integer, got {raw!r}")
        value: Any = raw
    elif spec.unit:
        value = _parse_quantity(spec, spec.unit, raw, where)
    else:
        value = _parse_array(spec, raw, where)
    if spec.check is not None:
        predicate, text = spec.check
        if not predicate(value):
            raise ConfigError(f"{where}: expected {text}, got {raw!r}")
    return value


def shape_matches(declared: tuple[int, ...], shape: tuple[int, ...]) -> bool:
    """Whether an array's shape is the declared one (a -1 stands for any length >= 1)."""
    return len(declared) == len(shape) and all(d == n or (d == -1 and n >= 1) for d, n in zip(declared, shape, strict=True))


def shape_text(declared: tuple[int, ...]) -> str:
    """A declared shape as the messages write it: (3,), (n, 3) with n >= 1."""
    if -1 not in declared:
        return str(declared)
    dims = ", ".join("n" if d == -1 else str(d) for d in declared)
    return f"({dims},) with n >= 1" if len(declared) == 1 else f"({dims}) with n >= 1"


def _parse_array(spec: Spec, raw: Any, where: str) -> Any:
    if isinstance(raw, (bool, str, Mapping)):
        raise ConfigError(f"{where}: expected a number or array of numbers, got {raw!r}")
    try:
        arr = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: expected numbers, got {raw!r}") from exc
    if not shape_matches(spec.shape, arr.shape):
        raise ConfigError(f"{where}: expected shape {shape_text(spec.shape)}, got {arr.shape} ({raw!r})")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"{where}: non-finite value in {raw!r}")
    if spec.shape == ():
        return float(arr)
    arr.setflags(write=False)
    return arr


def _parse_quantity(spec: Spec, unit: str, raw: Any, where: str) -> Any:
    if spec.shape == ():
        if not isinstance(raw, str):
            raise ConfigError(f"{where}: expected a string with a unit like '1 {unit}', got {raw!r}")
        text, magnitude = raw, None
    else:
        if not isinstance(raw, Mapping) or set(raw) != {"value", "unit"}:
            raise ConfigError(f'{where}: expected a table {{value = [...], unit = "{unit}"}}, got {raw!r}')
        if not isinstance(raw["unit"], str):
            raise ConfigError(f"{where}.unit: expected a string, got {raw['unit']!r}")
        text, magnitude = raw["unit"], _parse_array(spec, raw["value"], f"{where}.value")
    q = parse_units(text, where)
    if not same_kind(q, unit):
        raise ConfigError(f"{where}: expected {spec.quantity} [{unit}], got {raw!r} [{describe(q)}]")
    si = float(q.to(unit).magnitude)
    if magnitude is None:
        if not math.isfinite(si):
            raise ConfigError(f"{where}: non-finite value {raw!r}")
        return si
    scale = float(UREG.Quantity(1.0, text).to(unit).magnitude)
    arr = magnitude * scale
    arr.setflags(write=False)
    return arr
