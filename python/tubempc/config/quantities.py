"""Quantities with units: the kinds the configuration knows and the pint parsing of a unit text."""

from __future__ import annotations

import math
import re
from typing import Any

import pint


class ConfigError(ValueError):
    """Invalid scenario configuration; the message names the file and the dotted field."""


#: The kinds of quantity of the configuration: name (in messages and the docs) -> SI unit, a value's
#: unit after parsing. A unit text of another kind is named by the first kind of its dimension here.
KINDS: dict[str, str] = {
    "gravitational parameter": "m^3/s^2",
    "length": "m",
    "SRP coefficient": "m^3/s^2",
    "density": "kg/m^3",
    "time": "s",
    "moment of inertia": "kg*m^2",
    "acceleration": "m/s^2",
    "torque": "N*m",
    "angle": "rad",
    "velocity": "m/s",
    "angular velocity": "rad/s",
    "length^2": "m^2",
    "velocity^2": "m^2/s^2",
    "angle^2": "rad^2",
    "angular velocity^2": "rad^2/s^2",
    "angle random walk": "rad/s/Hz^0.5",
    "rate random walk": "rad/s^2/Hz^0.5",
    "velocity random walk": "m/s^2/Hz^0.5",
    "acceleration random walk": "m/s^3/Hz^0.5",
    "mass": "kg",
    "area": "m^2",
    "pressure": "N/m^2",
}

UREG: Any = pint.UnitRegistry()
ANGLE_UNITS = frozenset({"radian", "degree", "arcminute", "arcsecond", "turn", "revolution", "milliradian"})

# A power operator and what follows it: an exponent must be a plain number, not another power.
_POWER = re.compile(r"(?:\*\*|\^)\s*\(?\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)?\s*\)?\s*(\*\*|\^)?")
_MAX_EXPONENT = 10.0
_MAX_QUANTITY_CHARS = 200


def angle_power(q: Any) -> int:
    """Total exponent of angle units in q (pint treats angles as dimensionless)."""
    return sum(round(float(p)) for name, p in q.unit_items() if name in ANGLE_UNITS)


def same_kind(q: Any, unit: str) -> bool:
    """Whether q converts to ``unit`` with its angles: the same dimension and the same power of angle."""
    ref = UREG.Quantity(1.0, unit)
    return bool(ref.dimensionality == q.dimensionality) and angle_power(ref) == angle_power(q)


def describe(q: Any) -> str:
    """Name of q's kind among :data:`KINDS`, else its pint dimensionality."""
    for name, unit in KINDS.items():
        if same_kind(q, unit):
            return name
    return "dimensionless" if q.dimensionless else str(q.dimensionality)


def check_powers(text: str, where: str) -> None:
    """Rejects what pint would take very long to evaluate (``10**10**10``: Python integers)."""
    if len(text) > _MAX_QUANTITY_CHARS:
        raise ConfigError(f"{where}: quantity text longer than {_MAX_QUANTITY_CHARS} characters")
    for m in _POWER.finditer(text):
        exponent, chained = m.group(1), m.group(2)
        try:
            ok = exponent is not None and chained is None and abs(float(exponent)) <= _MAX_EXPONENT
        except ValueError:
            ok = False
        if not ok:
            raise ConfigError(
                f"{where}: in {text[:60]!r}, every power must be a single number of magnitude "
                f"<= {_MAX_EXPONENT:g} (e.g. 'kg/m^3')"
            )


def parse_units(text: str, where: str) -> Any:
    """The pint quantity of a text such as "0.55 m/s^2" or "deg"; ConfigError when it is no quantity."""
    check_powers(text, where)
    try:
        q: Any = UREG.Quantity(text)
    except Exception as exc:  # pint raises several unrelated exception types
        raise ConfigError(f"{where}: cannot parse {text!r} as a quantity: {exc}") from exc
    if not all(math.isfinite(float(p)) for _, p in q.unit_items()):
        raise ConfigError(f"{where}: non-finite unit exponent in {text!r}")
    return q
