"""The whole configuration (``Config``, its sections in order) and its parsing from TOML content: old
spellings, unknown and missing fields, and the checks that involve more than one field."""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path
from typing import Any, TypeVar, get_type_hints

import numpy as np
import tomli_w

from .abort import AbortSection
from .faults import ACTUATOR_FAULT_KINDS, FAULT_KINDS, SENSOR_FAULT_KINDS, FaultsSection
from .fields import encode, is_si, parse_field, spec_of
from .navigation import NavigationSection
from .physical import PhysicalSection
from .quantities import ConfigError
from .sections import (
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

#: Fields that a file leaving them out takes from its own spacecraft.boresight_B (not from the packaged
#: file): the altimeter's beam and the camera's optical axis lie along the boresight unless mounted otherwise.
BORESIGHT_DEFAULTS: tuple[tuple[str, str], ...] = (
    ("navigation", "altimeter_boresight_B"),
    ("navigation", "camera_boresight_B"),
)


@dataclass(frozen=True, eq=False)
class Config:
    """The whole scenario in SI, one field per section in the order of the file. `source` (the file it
    came from) is not part of the content: it is left out of to_dict(), equality and hash()."""

    environment: EnvironmentSection
    asteroid: AsteroidSection
    spacecraft: SpacecraftSection
    constraints: ConstraintsSection
    mpc: MpcSection
    boundary: BoundarySection
    identification: IdentificationSection
    disturbance: DisturbanceSection
    tube: TubeSection
    simulation: SimulationSection
    navigation: NavigationSection
    physical: PhysicalSection
    faults: FaultsSection
    abort: AbortSection
    source: str = "<memory>"
    defaulted: tuple[str, ...] = ()  # "section.field" taken from the packaged defaults (not content)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """TOML-ready content in SI units (load(save(c)) == c exactly)."""
        return {name: _section_to_dict(getattr(self, name)) for name in SECTIONS}

    def save(self, path: str | Path) -> None:
        Path(path).write_bytes(tomli_w.dumps(self.to_dict()).encode())

    def hash(self) -> str:
        """sha256 of the canonical content (sorted JSON of to_dict())."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def with_overrides(self, overrides: Mapping[str, Any]) -> Config:
        """Copy with dotted fields replaced, e.g. {"identification.lambda_p": 0.97}.

        A value is SI (number or nested list) or, for a quantity, a string with its unit or
        a {value, unit} table; the result is validated like a file.
        """
        data = self.to_dict()
        for key, value in overrides.items():
            section, _, name = key.partition(".")
            if section not in data or name not in data[section]:
                raise ConfigError(f"{self.source} (override): {key}: unknown field")
            spec = spec_of(SECTIONS[section], name)
            data[section][name] = encode(spec, value) if is_si(spec, value) else value
        if "spacecraft.boresight_B" in overrides:  # a sensor left out of the file follows the boresight
            for section, name in BORESIGHT_DEFAULTS:
                if f"{section}.{name}" in self.defaulted and f"{section}.{name}" not in overrides:
                    data[section][name] = data["spacecraft"]["boresight_B"]
        changed = parse(data, f"{self.source} (override)")
        return Config(**{name: getattr(changed, name) for name in SECTIONS}, source=changed.source, defaulted=self.defaulted)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Config) and self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(self.hash())


#: The sections, name -> class, in the order of Config's fields (and of a saved file).
SECTIONS: dict[str, type] = {
    name: cls for name, cls in get_type_hints(Config).items() if isinstance(cls, type) and is_dataclass(cls)
}


def _section_to_dict(section: Any) -> dict[str, Any]:
    return {f.name: encode(f.metadata["spec"], getattr(section, f.name)) for f in fields(section)}


class ConfigDeprecationWarning(FutureWarning):
    """A configuration file uses an old spelling (still read) or a field that is now ignored."""


#: Old field names (section, old) -> new name; read with a warning.
RENAMED_FIELDS: dict[tuple[str, str], str] = {("mpc", "N"): "horizon", ("mpc", "eps"): "scp_eps"}
#: Old option values (section, field, old) -> new value; read with a warning.
RENAMED_VALUES: dict[tuple[str, str, str], str] = {
    ("mpc", "input_cost", "paper"): "absolute",
    ("simulation", "integrator", "dopri"): "dopri5",
    ("disturbance", "model", "ellipsoid_uniform"): "drawn",
}
#: Fields that nothing read; ignored with a warning.
REMOVED_FIELDS: frozenset[tuple[str, str]] = frozenset({("asteroid", "G"), ("asteroid", "shape_mean_radius")})

#: Old fields whose meaning changed (section, old) -> how to write it now; a ConfigError.
REPLACED_FIELDS: dict[tuple[str, str], str] = {
    ("identification", "prior_weight"): (
        "replaced by prior_memory, the prior's weight in units of the steady-state weight q / (1 - q), "
        "q = e^(lambda - 1) (1: one full memory, the default; 0: the literal recursion, as prior_weight = 0)"
    ),
}


def _upgrade(section: str, raw: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The section with old spellings replaced (each with a ConfigDeprecationWarning)."""
    out: dict[str, Any] = {}
    for key, value in raw.items():
        if (section, key) in REPLACED_FIELDS:
            raise ConfigError(f"{where}.{key}: {REPLACED_FIELDS[(section, key)]}")
        if (section, key) in REMOVED_FIELDS:
            warnings.warn(
                f"{where}.{key}: the field is no longer used and is ignored; remove it",
                ConfigDeprecationWarning,
                stacklevel=4,
            )
            continue
        new = RENAMED_FIELDS.get((section, key))
        if new is not None:
            if new in raw:
                raise ConfigError(f"{where}.{key}: old name of {new}, which is also given; keep only {new}")
            warnings.warn(f"{where}.{key}: renamed to {new}; read as {new}", ConfigDeprecationWarning, stacklevel=4)
            key = new
        if isinstance(value, str) and (section, key, value) in RENAMED_VALUES:
            new_value = RENAMED_VALUES[(section, key, value)]
            warnings.warn(
                f"{where}.{key}: value {value!r} renamed to {new_value!r}; read as {new_value!r}",
                ConfigDeprecationWarning,
                stacklevel=4,
            )
            value = new_value
        out[key] = value
    return out


_S = TypeVar("_S")


def _parse_section(
    cls: type[_S], section: str, raw: Any, where: str, defaults: Mapping[str, Any] | None, defaulted: list[str]
) -> _S:
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{where}: expected a table, got {raw!r}")
    raw = _upgrade(section, raw, where)
    names = [f.name for f in fields(cls)]  # type: ignore[arg-type]
    unknown = sorted(set(raw) - set(names))
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown field (known: {', '.join(names)})")
    missing = [n for n in names if n not in raw]
    if missing and defaults is None:
        raise ConfigError(f"{where}.{missing[0]}: missing field")
    raw = {**raw, **{n: defaults[n] for n in missing}} if defaults is not None else raw
    defaulted.extend(f"{section}.{n}" for n in missing)
    values = {
        f.name: parse_field(f.metadata["spec"], raw[f.name], f"{where}.{f.name}")
        for f in fields(cls)  # type: ignore[arg-type]
    }
    return cls(**values)


def parse(data: Mapping[str, Any], source: str, defaults: Mapping[str, Any] | None = None) -> Config:
    """A validated Config from TOML content; with ``defaults`` (raw content of a complete file),
    missing sections and fields are taken from it and listed in ``Config.defaulted``."""
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise ConfigError(f"{source}: {unknown[0]}: unknown section (known: {', '.join(SECTIONS)})")
    missing = [s for s in SECTIONS if s not in data]
    if missing and defaults is None:
        raise ConfigError(f"{source}: {missing[0]}: missing section")
    defaulted: list[str] = []
    sections: dict[str, Any] = {
        name: _parse_section(
            cls, name, data.get(name, {}), f"{source}: {name}", None if defaults is None else defaults[name], defaulted
        )
        for name, cls in SECTIONS.items()
    }
    config = Config(**sections, source=source, defaulted=tuple(defaulted))
    _check_consistency(config)
    return config


def _multiple(period: float, base: float) -> bool:
    r = period / base
    return round(r) >= 1 and abs(r - round(r)) <= 1e-9 * r


def _check_navigation(c: Config) -> None:
    """The sensors' periods and mpc.dt are integer multiples of the IMU's; each range interval is non-empty."""
    n = c.navigation
    for name in ("altimeter_period", "camera_period", "star_tracker_period"):
        if not _multiple(getattr(n, name), n.imu_period):
            raise ConfigError(
                f"{c.source}: navigation.{name}: {getattr(n, name)} s is not an integer multiple of "
                f"navigation.imu_period = {n.imu_period} s"
            )
    if not _multiple(c.mpc.dt, n.imu_period):
        raise ConfigError(
            f"{c.source}: navigation.imu_period: mpc.dt = {c.mpc.dt} s is not an integer multiple of {n.imu_period} s"
        )
    if n.site_landmarks > 0 and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: navigation.site_landmarks: site landmarks need boundary.terminal = "site"')
    for sensor in ("altimeter", "camera"):
        lo, hi = getattr(n, f"{sensor}_min_range"), getattr(n, f"{sensor}_max_range")
        if not hi > lo:
            raise ConfigError(f"{c.source}: navigation.{sensor}_max_range: {hi} m must exceed {sensor}_min_range = {lo} m")


def _check_physical(c: Config) -> None:
    """The plate_* arrays have one entry per plate and each plate reflects at most what it receives; the truth's
    SRP with disturbance.model = "physical" is the plates', not simulation.srp_scale's."""
    p = c.physical
    n = p.n_plates
    for name in ("plate_normal_B", "plate_center_B", "plate_specular", "plate_diffuse"):
        rows = np.asarray(getattr(p, name)).shape[0]
        if rows != n:
            raise ConfigError(
                f"{c.source}: physical.{name}: {rows} entries, but physical.plate_area has {n} (one per plate)"
            )
    total = np.asarray(p.plate_specular) + np.asarray(p.plate_diffuse)
    if np.any(total > 1.0):
        i = int(np.argmax(total > 1.0))
        raise ConfigError(
            f"{c.source}: physical.plate_diffuse: plate {i}: specular + diffuse = {total[i]:g} exceeds 1 "
            "(a plate reflects at most what it receives)"
        )
    _check_dispersion_ranges(c)
    if c.disturbance.model == "physical" and c.simulation.srp_scale != 1.0:
        raise ConfigError(
            f'{c.source}: simulation.srp_scale: must be 1 with disturbance.model = "physical" (the truth\'s SRP is '
            "the physical section's flat plates; the controller keeps environment.beta_srp)"
        )


def _check_dispersion_ranges(c: Config) -> None:
    """Every value a campaign run can draw (the nominal +- its *_dispersion) satisfies the nominal's own check:
    mass_error in (-0.5, 0.5), inertia_scale in (0.5, 2), each plate's coefficients in [0, 1] with specular +
    diffuse <= 1. (The truth's inertia and the body's densities over their ranges are checked with the scenario:
    tubempc.scenario.physical.)"""
    p = c.physical

    def refuse(name: str, what: str) -> None:
        raise ConfigError(f"{c.source}: physical.{name}: {what}")

    lo, hi = p.mass_error - p.mass_error_dispersion, p.mass_error + p.mass_error_dispersion
    if not -0.5 < lo <= hi < 0.5:
        refuse(
            "mass_error_dispersion",
            f"mass_error {p.mass_error:g} +- {p.mass_error_dispersion:g} spans [{lo:g}, {hi:g}], which leaves (-0.5, 0.5)",
        )
    scale, ds = np.asarray(p.inertia_scale), np.asarray(p.inertia_scale_dispersion)
    if np.any(scale - ds <= 0.5) or np.any(scale + ds >= 2.0):
        i = int(np.argmax((scale - ds <= 0.5) | (scale + ds >= 2.0)))
        refuse(
            "inertia_scale_dispersion",
            f"axis {i}: inertia_scale {scale[i]:g} +- {ds[i]:g} spans [{scale[i] - ds[i]:g}, {scale[i] + ds[i]:g}], "
            "which leaves (0.5, 2)",
        )
    specular, diffuse = np.asarray(p.plate_specular), np.asarray(p.plate_diffuse)
    for name, values, d in (
        ("plate_specular_dispersion", specular, p.plate_specular_dispersion),
        ("plate_diffuse_dispersion", diffuse, p.plate_diffuse_dispersion),
    ):
        bad = (values - d < 0.0) | (values + d > 1.0)
        if np.any(bad):
            i = int(np.argmax(bad))
            coefficient = name.removesuffix("_dispersion")
            refuse(
                name,
                f"plate {i}: {coefficient} {values[i]:g} +- {d:g} spans [{values[i] - d:g}, {values[i] + d:g}], which "
                "leaves [0, 1]",
            )
    most = specular + diffuse + p.plate_specular_dispersion + p.plate_diffuse_dispersion
    if np.any(most > 1.0):
        i = int(np.argmax(most > 1.0))
        refuse(
            "plate_diffuse_dispersion",
            f"plate {i}: specular + diffuse can reach {most[i]:g} over their dispersions, more than 1 (a plate reflects "
            "at most what it receives)",
        )


def _check_faults(c: Config) -> None:
    """Every random kind is a fault kind; a fault inside the run."""
    f = c.faults
    kinds = f.random_kind_list
    if not kinds:
        raise ConfigError(f"{c.source}: faults.random_kinds: no kind given (known: {', '.join(FAULT_KINDS)})")
    for k in kinds:
        if k not in FAULT_KINDS:
            raise ConfigError(
                f"{c.source}: faults.random_kinds: {k!r} is not a fault kind (known: {', '.join(FAULT_KINDS)})"
            )
    sensor = [k for k in (kinds if f.random else (f.kind,)) if k in SENSOR_FAULT_KINDS]
    if sensor and not c.navigation.enabled:
        name = "faults.random_kinds" if f.random else "faults.kind"
        raise ConfigError(f"{c.source}: {name}: the sensor fault {sensor[0]!r} needs navigation.enabled = true")
    actuator = [k for k in (kinds if f.random else (f.kind,)) if k in ACTUATOR_FAULT_KINDS]
    if actuator and c.spacecraft.actuators == "ideal":
        name = "faults.random_kinds" if f.random else "faults.kind"
        raise ConfigError(
            f'{c.source}: {name}: the actuator fault {actuator[0]!r} needs spacecraft.actuators other than "ideal"'
        )
    if f.kind != "none" and not f.random and f.start >= c.mpc.t_f:
        raise ConfigError(
            f"{c.source}: faults.start: {f.start} s is not before the end of the run (mpc.t_f = {c.mpc.t_f} s)"
        )
    if f.random and f.random_window[1] > c.mpc.t_f:
        raise ConfigError(
            f"{c.source}: faults.random_window: its end {f.random_window[1]} s is after the end of the run "
            f"(mpc.t_f = {c.mpc.t_f} s)"
        )


def _check_abort(c: Config) -> None:
    """An abort hovers above its safe altitude, at a site, and a commanded abort falls inside the run."""
    a = c.abort
    if not a.enabled:
        return
    if c.boundary.terminal != "site":
        raise ConfigError(
            f'{c.source}: abort.enabled: the abort hovers above the landing site: it needs boundary.terminal = "site"'
        )
    if a.safe_altitude >= a.hover_altitude:
        raise ConfigError(
            f"{c.source}: abort.safe_altitude: {a.safe_altitude} m must be below abort.hover_altitude = {a.hover_altitude} m"
        )
    if a.command_time >= c.mpc.t_f:
        raise ConfigError(
            f"{c.source}: abort.command_time: {a.command_time} s is not before the end of the run (mpc.t_f = {c.mpc.t_f} s)"
        )


def _check_consistency(c: Config) -> None:
    _check_navigation(c)
    _check_physical(c)
    _check_faults(c)
    _check_abort(c)
    ratio = c.mpc.t_f / c.mpc.dt
    if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
        raise ConfigError(f"{c.source}: mpc.t_f: {c.mpc.t_f} s is not a multiple of mpc.dt = {c.mpc.dt} s")
    if c.constraints.glide_slope_apex == "site" and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: constraints.glide_slope_apex: "site" needs boundary.terminal = "site"')
    if c.constraints.glide_slope_axis != "z" and c.boundary.terminal != "site":
        raise ConfigError(
            f'{c.source}: constraints.glide_slope_axis: {c.constraints.glide_slope_axis!r} needs boundary.terminal = "site"'
        )
    if c.boundary.initial == "hover" and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: boundary.initial: "hover" needs boundary.terminal = "site"')
    if c.boundary.touchdown_speed > 0.0 and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: boundary.touchdown_speed: a touchdown speed needs boundary.terminal = "site"')
    if c.mpc.scp_mode == "real_time" and c.mpc.linearization != "reuse":
        raise ConfigError(f'{c.source}: mpc.scp_mode: "real_time" needs mpc.linearization = "reuse"')
    if c.mpc.horizon > c.mpc.n_steps:
        raise ConfigError(f"{c.source}: mpc.horizon: horizon {c.mpc.horizon} exceeds t_f / dt = {c.mpc.n_steps} steps")
    if c.spacecraft.actuators != "ideal":
        for name in ("scale_error_p", "misalignment_p", "scale_error_r", "misalignment_r"):
            if getattr(c.disturbance, name) != 0.0:
                raise ConfigError(
                    f"{c.source}: disturbance.{name}: must be 0 with spacecraft.actuators = {c.spacecraft.actuators!r} "
                    "(the actuator model draws its own thruster errors within the preset's bounds)"
                )
    if c.tube.design_adoption == "when_ready" and c.tube.design_worker == "inline":
        raise ConfigError(f'{c.source}: tube.design_adoption: "when_ready" needs a concurrent tube.design_worker')
