"""Scenario configuration: one TOML file with units, parsed into SI (docs/model.md "Scenario", which
names each value's setting and source; docs/configuration.md lists every field).

Quantities are written with units: a scalar as a string ("0.55 m/s^2", "70 deg"), a vector
or matrix as a table {value = [...], unit = "m"}; dimensionless numbers (N, forgetting
factors, weights) as plain numbers; options as strings. Parsing uses pint; the result is a
tree of frozen dataclasses holding SI floats and read-only numpy arrays (angles in rad).
Every problem raises ConfigError naming the file and the dotted field.

Each field is declared once, in its section's dataclass (sections.py, navigation.py): its kind and
unit, shape, check, documentation line and, for [navigation], the C++ setting it sets (fields.py).
"""

from __future__ import annotations

from .abort import AbortSection
from .faults import FAULT_KINDS, FaultsSection
from .load import OWN_MISSION_DEFAULTS, SCENARIOS, load_config, scenario_file
from .navigation import NavigationSection
from .parse import (
    BORESIGHT_DEFAULTS,
    REMOVED_FIELDS,
    RENAMED_FIELDS,
    RENAMED_VALUES,
    REPLACED_FIELDS,
    Config,
    ConfigDeprecationWarning,
)
from .physical import PhysicalSection
from .quantities import ConfigError
from .sections import (
    PLANTS,
    AsteroidSection,
    BoundarySection,
    ConstraintsSection,
    DisturbanceSection,
    EnvironmentSection,
    IdentificationSection,
    MpcSection,
    SimulationSection,
    SpacecraftSection,
    TubeSection,
)

__all__ = [
    "BORESIGHT_DEFAULTS",
    "FAULT_KINDS",
    "OWN_MISSION_DEFAULTS",
    "PLANTS",
    "REMOVED_FIELDS",
    "RENAMED_FIELDS",
    "RENAMED_VALUES",
    "REPLACED_FIELDS",
    "SCENARIOS",
    "AbortSection",
    "AsteroidSection",
    "BoundarySection",
    "Config",
    "ConfigDeprecationWarning",
    "ConfigError",
    "ConstraintsSection",
    "DisturbanceSection",
    "EnvironmentSection",
    "FaultsSection",
    "IdentificationSection",
    "MpcSection",
    "NavigationSection",
    "PhysicalSection",
    "SimulationSection",
    "SpacecraftSection",
    "TubeSection",
    "load_config",
    "scenario_file",
]
