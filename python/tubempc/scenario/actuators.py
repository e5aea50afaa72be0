"""Actuator presets: a spacecraft's thrusters and reaction wheels from a TOML file with units
(docs/model.md "Actuators"), built into the C++ objects of :mod:`tubempc._core.actuators`.

A preset names its figures' public sources in comments (``python/tubempc/data/spacecraft/``). Quantities
are strings or ``{value = [...], unit = "..."}`` tables parsed with pint; plain numbers are dimensionless.
A preset may name another as its ``base`` (a preset name or a path relative to its folder): the base's
sections are taken, a table of the preset's is merged into the base's field by field and any other entry
(``[[thrusters]]``, ``[[faults]]``) replaces the base's. Faults are ``[[faults]]`` entries (``thruster``,
``kind`` = "failed_off" or "stuck_on", ``time`` a quantity or "random" with ``window`` = [start, end]); a random
time is drawn with ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import functools
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._core import actuators as _act
from .._core import so3 as _so3

FloatArray = NDArray[np.float64]

#: Directory of the presets.
PRESET_DIR = Path(__file__).parents[1] / "data" / "spacecraft"

_THRUSTER_FIELDS = {
    "max_thrust": "N",
    "min_on_time": "s",
    "isp": "s",
    "scale_error_bound": "",
    "misalignment_bound": "rad",
    "scale_error": "",
}


class ActuatorConfigError(ValueError):
    """Invalid actuator preset; the message names the file and the field."""


_SECTIONS = {"base", "name", "mass", "thruster_defaults", "thrusters", "wheels", "momentum_dump", "modulation", "faults"}
_SECTION_KEYS = {
    "thruster_defaults": set(_THRUSTER_FIELDS) | {"misalignment_B"},
    "wheels": {"max_torque", "max_momentum", "axes_B"},
    "momentum_dump": {"enabled", "start_fraction", "stop_fraction", "time_constant"},
    "modulation": {"on_time_resolution", "rounding", "opposed_pairs"},
}


def _known(table: Any, keys: set[str], where: str) -> None:
    """Rejects a key outside `keys` (a misspelt field would otherwise be ignored)."""
    if not isinstance(table, Mapping):
        raise ActuatorConfigError(f"{where}: expected a table, got {table!r}")
    unknown = sorted(set(table) - keys)
    if unknown:
        raise ActuatorConfigError(f"{where}: unknown field(s) {unknown}; expected some of {sorted(keys)}")


@functools.cache
def _ureg() -> Any:
    import pint  # deferred: `import tubempc` does not load pint

    return pint.UnitRegistry()


def _quantity(raw: Any, unit: str, where: str) -> float:
    """A scalar in SI `unit` from a string with a unit ('20 ms'); a plain number if `unit` is ''."""
    if unit == "":
        if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw):
            raise ActuatorConfigError(f"{where}: expected a finite number, got {raw!r}")
        return float(raw)
    if not isinstance(raw, str):
        raise ActuatorConfigError(f"{where}: expected a string with a unit like '1 {unit}', got {raw!r}")
    try:
        q = _ureg().Quantity(raw)
        value = float(q.to(unit).magnitude)
    except Exception as exc:  # pint raises several unrelated exception types
        raise ActuatorConfigError(f"{where}: cannot read {raw!r} as [{unit}]: {exc}") from exc
    if not math.isfinite(value):
        raise ActuatorConfigError(f"{where}: non-finite value {raw!r}")
    return value


def _vector(raw: Any, unit: str, where: str, shape: tuple[int, ...] = (3,)) -> FloatArray:
    """An array in SI `unit` from {value = [...], unit = "..."}; a plain array of numbers if `unit` is ''."""
    scale = 1.0
    if unit != "":
        if not isinstance(raw, Mapping) or set(raw) != {"value", "unit"}:
            raise ActuatorConfigError(f'{where}: expected a table {{value = [...], unit = "{unit}"}}, got {raw!r}')
        scale = _quantity(f"1 {raw['unit']}", unit, f"{where}.unit")
        raw = raw["value"]
    try:
        arr = np.asarray(raw, dtype=np.float64) * scale
    except (TypeError, ValueError) as exc:
        raise ActuatorConfigError(f"{where}: expected numbers, got {raw!r}") from exc
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise ActuatorConfigError(f"{where}: expected {shape} finite numbers, got {raw!r}")
    return arr


@dataclass(frozen=True, eq=False)
class ActuatorSuite:
    """A spacecraft's actuators: its mass (kg), thrusters, wheels and the settings for a control period."""

    name: str
    mass: float
    cluster: _act.ThrusterCluster
    wheels: _act.ReactionWheels
    modulation: _act.ModulationSettings
    allocation: _act.AllocationSettings
    path: Path | None = None  # the file read
    random_faults: bool = False  # whether a fault's thruster or time was drawn (from the seed)

    def allocator(self) -> _act.Allocator:
        """A new allocator for these actuators."""
        return _act.Allocator(self.cluster, self.wheels, self.allocation)

    def modulator(self) -> _act.PulseModulator:
        """A new pulse modulator for these thrusters."""
        return _act.PulseModulator(self.cluster, self.modulation)


def preset_names() -> list[str]:
    """The names of the shipped presets."""
    return sorted(p.stem for p in PRESET_DIR.glob("*.toml"))


def _thruster(raw: Mapping[str, Any], defaults: Mapping[str, Any], where: str) -> _act.ThrusterSpec:
    s = _act.ThrusterSpec()
    merged = {**defaults, **raw}
    unknown = set(merged) - set(_THRUSTER_FIELDS) - {"position_B", "direction_B", "misalignment_B"}
    if unknown:
        raise ActuatorConfigError(f"{where}: unknown field(s) {sorted(unknown)}")
    for key in ("position_B", "direction_B"):
        if key not in merged:
            raise ActuatorConfigError(f"{where}.{key}: missing")
    s.position_B = _vector(merged["position_B"], "m", f"{where}.position_B")
    direction = _vector(merged["direction_B"], "", f"{where}.direction_B")
    norm = float(np.linalg.norm(direction))
    if not abs(norm - 1.0) < 1e-6:
        raise ActuatorConfigError(f"{where}.direction_B: expected a unit vector, got norm {norm}")
    s.direction_B = direction / norm
    for key, unit in _THRUSTER_FIELDS.items():
        if key in merged:
            setattr(s, key, _quantity(merged[key], unit, f"{where}.{key}"))
    if "misalignment_B" in merged:
        s.misalignment_B = _vector(merged["misalignment_B"], "rad", f"{where}.misalignment_B")
    try:
        s.validate(where)
    except ValueError as exc:
        raise ActuatorConfigError(str(exc)) from exc
    return s


def _read_preset(path: Path, where: str) -> dict[str, Any]:
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except OSError as exc:
        raise ActuatorConfigError(f"{where}: cannot read: {exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ActuatorConfigError(f"{where}: not TOML: {exc}") from exc


def _with_base(raw: dict[str, Any], path: Path, where: str, seen: tuple[Path, ...] = ()) -> dict[str, Any]:
    """`raw` over its ``base`` preset (itself over its own base): tables merged field by field, any other entry
    replaced. ActuatorConfigError on a cycle of bases."""
    name = raw["base"]
    if not isinstance(name, str) or not name:
        raise ActuatorConfigError(f"{where}.base: expected a preset name or a TOML path, got {name!r}")
    base_path = Path(name)
    base_path = (path.parent / base_path if base_path.suffix else PRESET_DIR / f"{name}.toml").resolve()
    seen = (*seen, path.resolve())
    if base_path in seen:
        raise ActuatorConfigError(f"{where}.base: {base_path.name} is a base of itself")
    base_where = f"{where}.base ({base_path.name})"
    base = _read_preset(base_path, base_where)
    _known(base, _SECTIONS, base_where)
    if "base" in base:
        base = _with_base(base, base_path, base_where, seen)
    merged = {k: v for k, v in base.items() if k != "name"}  # a preset's name is its own (or its file's)
    for key, value in raw.items():
        if key == "base":
            continue
        old = merged.get(key)
        merged[key] = {**old, **value} if isinstance(old, Mapping) and isinstance(value, Mapping) else value
    return merged


def load_actuators(source: str | Path, period: float, *, seed: int = 0) -> ActuatorSuite:
    """Reads a preset (a name of :func:`preset_names` or a path) for a control period (s).

    Truth errors are 0 unless the file gives them (:func:`sample_truth_errors` draws them); faults are
    applied to the cluster; a random fault time is drawn with ``numpy.random.default_rng(seed)``.
    """
    path = Path(source)
    if not path.suffix:
        path = PRESET_DIR / f"{source}.toml"
    where = path.name
    raw = _read_preset(path, where)
    _known(raw, _SECTIONS, where)
    if "base" in raw:
        raw = _with_base(raw, path, where)
    for section in ("thruster_defaults", "wheels", "momentum_dump", "modulation"):
        if section in raw:
            if not isinstance(raw[section], Mapping):
                raise ActuatorConfigError(f"{where}.{section}: expected a table")
            _known(raw[section], _SECTION_KEYS[section], f"{where}.{section}")
    for i, f in enumerate(raw.get("faults", [])):
        _known(f, {"thruster", "kind", "time", "window"}, f"{where}.faults[{i}]")
    if not (math.isfinite(period) and period > 0.0):
        raise ActuatorConfigError(f"{where}: period must be finite and > 0 (s), got {period!r}")
    mass = _quantity(raw.get("mass"), "kg", f"{where}.mass")
    if mass <= 0.0:
        raise ActuatorConfigError(f"{where}.mass: must be > 0")
    defaults = raw.get("thruster_defaults", {})
    units = raw.get("thrusters", [])
    if not isinstance(units, list) or not units:
        raise ActuatorConfigError(f"{where}.thrusters: expected [[thrusters]] entries")
    specs = [_thruster(t, defaults, f"{where}.thrusters[{i}]") for i, t in enumerate(units)]

    rng = np.random.default_rng(seed)
    random_faults = False
    for i, f in enumerate(raw.get("faults", [])):
        w = f"{where}.faults[{i}]"
        j = f.get("thruster")
        if j == "random":
            j = int(rng.integers(len(specs)))
            random_faults = True
        if isinstance(j, bool) or not isinstance(j, int) or not 0 <= j < len(specs):
            raise ActuatorConfigError(f'{w}.thruster: expected an index in [0, {len(specs)}) or "random", got {j!r}')
        try:
            specs[j].fault = _act.FaultKind.from_string(str(f.get("kind")))
        except ValueError as exc:
            raise ActuatorConfigError(f"{w}.kind: {exc}") from exc
        t = f.get("time")
        if t == "random":
            random_faults = True
            lo, hi = _vector(f.get("window"), "s", f"{w}.window", (2,))
            if not lo <= hi:
                raise ActuatorConfigError(f"{w}.window: expected start <= end")
            specs[j].fault_time = float(rng.uniform(lo, hi))
        else:
            specs[j].fault_time = _quantity(t, "s", f"{w}.time")

    rw = raw.get("wheels", {})
    dump = _act.MomentumDumpSettings()
    md = raw.get("momentum_dump", {})
    if "enabled" in md:
        dump.enabled = bool(md["enabled"])
    for key, unit in (("start_fraction", ""), ("stop_fraction", ""), ("time_constant", "s")):
        if key in md:
            setattr(dump, key, _quantity(md[key], unit, f"{where}.momentum_dump.{key}"))
    wheels: list[_act.ReactionWheelSpec] = []
    if rw:
        axes = np.asarray(rw.get("axes_B", []), dtype=np.float64)
        if axes.ndim != 2 or axes.shape[1] != 3:
            raise ActuatorConfigError(f"{where}.wheels.axes_B: expected a list of 3-vectors")
        for j, axis in enumerate(axes):
            s = _act.ReactionWheelSpec()
            s.axis_B = axis / np.linalg.norm(axis)
            s.max_torque = _quantity(rw.get("max_torque"), "N*m", f"{where}.wheels.max_torque")
            s.max_momentum = _quantity(rw.get("max_momentum"), "N*m*s", f"{where}.wheels.max_momentum")
            if abs(float(np.linalg.norm(axis)) - 1.0) > 1e-6:
                raise ActuatorConfigError(f"{where}.wheels.axes_B[{j}]: expected a unit vector")
            wheels.append(s)
    modulation = _act.ModulationSettings()
    modulation.period = period
    mod = raw.get("modulation", {})
    if "on_time_resolution" in mod:
        modulation.on_time_resolution = _quantity(mod["on_time_resolution"], "s", f"{where}.modulation.on_time_resolution")
    if "rounding" in mod:
        names = _act.PulseRounding.names()
        if mod["rounding"] not in names:
            raise ActuatorConfigError(f"{where}.modulation.rounding: expected one of {names}, got {mod['rounding']!r}")
        modulation.rounding = _act.PulseRounding.from_string(mod["rounding"])
    if "opposed_pairs" in mod:
        pairs = mod["opposed_pairs"]
        if not isinstance(pairs, bool):
            raise ActuatorConfigError(f"{where}.modulation.opposed_pairs: expected true or false, got {pairs!r}")
        modulation.opposed_pairs = pairs
    allocation = _act.AllocationSettings()
    allocation.period = period
    try:
        cluster = _act.ThrusterCluster(specs)
        wheel_set = _act.ReactionWheels(wheels, dump)
        modulation.validate()
        allocation.validate()
        _act.PulseModulator(cluster, modulation)  # every minimum on-time fits in the period
    except ValueError as exc:
        raise ActuatorConfigError(f"{where}: {exc}") from exc
    return ActuatorSuite(
        str(raw.get("name", path.stem)), mass, cluster, wheel_set, modulation, allocation, path, random_faults
    )


def sample_truth_errors(cluster: _act.ThrusterCluster, rng: np.random.Generator) -> _act.ThrusterCluster:
    """A copy of the cluster with truth errors drawn within each thruster's bounds: scale uniform in
    [-b, b], misalignment about a uniform random axis by an angle uniform in [0, bound]."""
    specs = []
    for i in range(len(cluster)):
        s = cluster.thruster(i)
        s.scale_error = float(rng.uniform(-1.0, 1.0)) * s.scale_error_bound
        axis = rng.normal(size=3)
        s.misalignment_B = axis / np.linalg.norm(axis) * float(rng.uniform(0.0, 1.0)) * s.misalignment_bound
        specs.append(s)
    return _act.ThrusterCluster(specs)


def actuation_settings(suite: ActuatorSuite) -> _act.ActuationSettings:
    """The settings of :class:`tubempc._core.actuators.ActuationSystem` for a preset's actuators."""
    s = _act.ActuationSettings()
    s.mass, s.modulation, s.allocation = suite.mass, suite.modulation, suite.allocation
    return s


#: "ideal": the paper's idealised spacecraft, a continuous input inside spacecraft.u_max / T_max (no actuator model).
IDEAL = "ideal"


@dataclass(frozen=True, eq=False)
class ScenarioActuation:
    """A scenario's actuators (``spacecraft.actuators``) and what the controller knows of them
    (docs/model.md "Actuators in the closed loop", M37-M38).

    ``box``: the inner box of the achievable wrench with any one thruster failed off (shape (1 N, 1 N m)
    per axis); ``u_max``, ``T_max``: the MPC's input bounds, the box's at every attitude, capped by
    spacecraft.u_max and T_max; ``error``: the certified box of the actuation error for the wrenches those
    bounds command (inside the box), with any one thruster failed.
    """

    source: str
    suite: ActuatorSuite
    box: _act.AchievableBox
    error: _act.ActuationErrorBound
    u_max: float
    T_max: float

    def system(self, seed: int, fault: tuple[str, int, float] | None = None) -> _act.ActuationSystem:
        """A run's actuation system: the preset's thrusters with truth errors drawn within their bounds
        from ``numpy.random.default_rng([seed, 1])`` and the preset's faults (random ones drawn from
        ``default_rng(seed)`` by :func:`load_actuators`: two independent streams), and the run's ``[faults]``
        actuator fault (kind, index, onset s; :func:`tubempc.scenario.faults.actuator_fault`): a thruster failed
        off or stuck on, or a wheel failed, from its onset to the end of the run."""
        suite = self.suite
        if suite.random_faults and suite.path is not None:
            suite = load_actuators(suite.path, suite.modulation.period, seed=seed)
        truth = sample_truth_errors(suite.cluster, np.random.default_rng([seed, 1]))
        wheels = self.suite.wheels
        if fault is not None:
            kind, index, onset = fault
            if kind == "wheel_failure":
                wheels = _act.ReactionWheels([wheels.wheel(j) for j in range(len(wheels))], wheels.dump_settings)
                wheels.set_failure(index, onset)
            else:
                truth.set_fault(index, _act.FaultKind.from_string(kind.removeprefix("thruster_")), onset)
        return _act.ActuationSystem(truth, wheels, actuation_settings(self.suite))

    def error_shapes(self) -> tuple[FloatArray, FloatArray]:
        """The certified sets of the commanded minus the delivered input (M38), {e : e^T E^-1 e <= 1}: u_p's
        ((m/s^2)^2, the ball at every attitude) and T's ((N m)^2, around the box). They add to the error box of
        :func:`tubempc._core.actuators.actuation_error_bound` (allocated minus delivered) the allocation's
        remainder tolerance over the achievable box, ``|r_i| <= tol (max_l W_r,l a_l + 1) / W_r,i``."""
        alloc = self.suite.allocation
        W_r = np.asarray(alloc.residual_weight)
        half = np.asarray(self.box.half_width_B)
        remainder = alloc.remainder_tolerance * (float(np.max(W_r * half)) + 1.0) / W_r
        wrench = np.asarray(self.error.wrench_B) + remainder
        radius_p = float(np.linalg.norm(wrench[:3])) / self.suite.mass
        return radius_p**2 * np.eye(3), 3.0 * np.diag(wrench[3:] ** 2)

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary for a run's record."""
        return {
            "actuators": self.source,
            "u_max": self.u_max,
            "T_max": self.T_max,
            "box_half_width_B": np.asarray(self.box.half_width_B).tolist(),
            "error_input": np.asarray(self.error.input).tolist(),
        }


def scenario_actuation(
    source: str, folder: Path, period: float, u_max: float, T_max: float, *, seed: int = 0
) -> ScenarioActuation | None:
    """The actuators of ``spacecraft.actuators`` = ``source`` (None for "ideal"): a preset name or a TOML
    path (relative to ``folder``), for the control period (s); ``u_max`` (m/s^2) and ``T_max`` (N m) are the
    configured bounds that cap the achievable box. ActuatorConfigError naming the file and field."""
    if source == IDEAL:
        return None
    path = Path(source)
    if path.suffix and not path.is_absolute():
        path = folder / path
    suite = load_actuators(path if path.suffix else source, period, seed=seed)
    settings = _act.AchievableBoxSettings()
    settings.tolerate_one_failure = True
    box = _act.achievable_box(suite.cluster, suite.wheels, suite.allocation, suite.mass, settings)
    if box.empty or not np.all(np.asarray(box.input_half_width) > 0.0):
        raise ActuatorConfigError(f"{source}: the actuators cannot deliver every direction with one thruster failed")
    half = np.asarray(box.input_half_width)
    u_max, T_max = min(u_max, float(half[:3].min())), min(T_max, float(half[3:].min()))
    # The wrenches the MPC can command: |u_p,i| <= u_max in L is a force of norm at most sqrt(3) m u_max, so
    # within that in each B axis too, at any attitude.
    command = np.minimum(np.r_[[math.sqrt(3.0) * suite.mass * u_max] * 3, [T_max] * 3], box.half_width_B)
    error = _act.actuation_error_bound(
        suite.cluster,
        suite.modulator(),
        suite.mass,
        suite.wheels,
        suite.allocation,
        command,
        0.0,
        True,
        math.sqrt(3.0) * suite.mass * u_max,
    )
    return ScenarioActuation(source, suite, box, error, u_max, T_max)


def actuate(system: _act.ActuationSystem, t: float, u: FloatArray, state: FloatArray) -> tuple[FloatArray, Any]:
    """One period of a run's actuators (M37): the command ``u`` [u_p (m/s^2, L); T (N m, B)] at time ``t`` (s)
    with the truth's 13-state ``state`` (its q_B/L gives C_BL = R(q_B/L)^T); returns the delivered input and
    the :class:`tubempc._core.actuators.ActuationStep`."""
    C_BL = np.asarray(_so3.rotation_matrix(np.asarray(state[6:10], dtype=np.float64))).T
    st = system.step(t, u, C_BL)
    return np.asarray(st.u_delivered, dtype=np.float64), st


def describe_actuation(system: _act.ActuationSystem, setup: ScenarioActuation | None) -> dict[str, Any]:
    """A run's actuation totals and the truth's thruster errors and faults (JSON-ready, for ``applied``)."""
    tot = system.totals
    cluster = system.cluster
    thrusters = [cluster.thruster(j) for j in range(len(cluster))]
    return {
        **({} if setup is None else setup.describe()),
        "delta_v": tot.delta_v,
        "propellant": tot.propellant,
        "impulse": tot.impulse,
        "pulses": int(tot.pulses),
        "not_delivered_steps": tot.not_delivered,
        "max_wheel_momentum_fraction": tot.max_wheel_momentum_fraction,
        "scale_error": [s.scale_error for s in thrusters],
        "misalignment_B": [np.asarray(s.misalignment_B).tolist() for s in thrusters],
        "faults": [
            {"thruster": j, "kind": str(s.fault), "time": s.fault_time}
            for j, s in enumerate(thrusters)
            if s.fault != _act.FaultKind.None_
        ],
    }
