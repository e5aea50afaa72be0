"""The fault a run flies ([faults]; docs/model.md M49-M51, issue #43): the one given (kind, start, duration) or, with
``faults.random``, one drawn from the run's seed with ``numpy.random.default_rng([seed, 43])`` (a kind of
``random_kinds``, its onset uniform in ``random_window``), as a JSON-ready dict that the run's ``applied`` keeps
(a re-flight of the run flies it again); the C++ navigation's sensor faults and detection settings of it; the
plant's disturbance burst."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _core
from ..config import Config
from ..config.faults import ACTUATOR_FAULT_KINDS, PLANT_FAULT_KINDS, SENSOR_FAULT_KINDS

__all__ = [
    "FAULT_SEED_STREAM",
    "actuator_fault",
    "burst_window",
    "detection_settings",
    "inject",
    "run_fault",
    "sensor_faults",
]

#: The second entry of the random fault's generator seed, ``default_rng([seed, 43])`` (issue #43).
FAULT_SEED_STREAM = 43


def _magnitude(cfg: Config, kind: str) -> float:
    f = cfg.faults
    return {
        "landmark_outlier": f.landmark_outlier_px,
        "altimeter_spike": f.altimeter_spike,
        "gyro_bias_step": f.gyro_bias_step,
        "accel_bias_step": f.accel_bias_step,
        "gyro_scale_step": f.imu_scale_step,
        "accel_scale_step": f.imu_scale_step,
        "disturbance_burst": f.burst_scale,
    }.get(kind, 0.0)


def run_fault(cfg: Config, seed: int) -> dict[str, Any] | None:
    """The fault run ``seed`` flies: {"kind", "start" (s), "duration" (s; None: to the end), "magnitude" (the kind's
    unit), "axis_B", "random"}; None without one."""
    f = cfg.faults
    rng = np.random.default_rng([int(seed), FAULT_SEED_STREAM])
    if f.random:
        kinds = f.random_kind_list
        kind = kinds[int(rng.integers(len(kinds)))]
        start = float(rng.uniform(f.random_window[0], f.random_window[1]))
    elif f.kind == "none":
        return None
    else:
        kind, start = f.kind, f.start
    # an actuator fault's unit: the given index, or a uniform draw in [0, 1) that the run's actuators resolve
    # (actuator_fault); drawn after the kind and the onset, so that those of a seed do not depend on it
    actuator_draw = float(rng.uniform()) if kind in ACTUATOR_FAULT_KINDS and f.actuator_index < 0 else None
    return {
        "kind": kind,
        "start": start,
        "duration": f.duration if f.duration > 0.0 else None,
        "magnitude": _magnitude(cfg, kind),
        "axis_B": (np.asarray(f.bias_axis_B) / np.linalg.norm(f.bias_axis_B)).tolist(),
        "random": f.random,
        **({"actuator_index": f.actuator_index, "actuator_draw": actuator_draw} if kind in ACTUATOR_FAULT_KINDS else {}),
    }


def actuator_fault(fault: dict[str, Any] | None, thrusters: int, wheels: int) -> tuple[str, int, float] | None:
    """A run's actuator fault as (kind, index, onset s) for actuators of ``thrusters`` thrusters and ``wheels``
    wheels (a drawn index: floor(draw n)); None for another fault or none. ValueError naming faults.actuator_index
    for an index beyond the actuators."""
    if fault is None or fault["kind"] not in ACTUATOR_FAULT_KINDS:
        return None
    kind = fault["kind"]
    n = wheels if kind == "wheel_failure" else thrusters
    if n == 0:
        raise ValueError(f"faults.kind: {kind!r} needs a {'wheel' if kind == 'wheel_failure' else 'thruster'}")
    draw = fault.get("actuator_draw")
    index = int(fault["actuator_index"]) if draw is None else min(int(float(draw) * n), n - 1)
    if not 0 <= index < n:
        raise ValueError(f"faults.actuator_index: {index} is not an index of the {n} actuators of its kind")
    return kind, index, float(fault["start"])


def _duration(fault: dict[str, Any]) -> float:
    return math.inf if fault["duration"] is None else float(fault["duration"])


def sensor_faults(fault: dict[str, Any] | None) -> list[Any]:
    """The C++ navigation's injected faults (``_core.nav.SensorFault``) of a run's fault (none for a plant's)."""
    if fault is None or fault["kind"] not in SENSOR_FAULT_KINDS:
        return []
    s = _core.nav.SensorFault()
    s.kind = _core.nav.SensorFaultKind.from_string(fault["kind"])
    s.t_start, s.duration, s.magnitude = fault["start"], _duration(fault), fault["magnitude"]
    s.axis_B = np.asarray(fault["axis_B"], dtype=np.float64)
    s.validate()
    return [s]


def detection_settings(cfg: Config) -> Any:
    """The navigation step's ``_core.nav.FaultDetectionSettings`` of [faults]."""
    f = cfg.faults
    d = _core.nav.FaultDetectionSettings()
    d.enabled, d.exclude = f.detection, f.exclude
    d.false_alarm_probability, d.persistence = f.false_alarm_probability, f.persistence
    d.outage_time, d.max_position_sigma = f.outage_time, f.max_position_sigma
    d.validate()
    return d


def inject(system: Any, cfg: Config, fault: dict[str, Any] | None) -> None:
    """Sets a run's sensor fault (if it is one) into its ``_core.nav.NavigationSystem``, with [faults]' detection."""
    system.set_faults(sensor_faults(fault), detection_settings(cfg))


def burst_window(fault: dict[str, Any] | None) -> tuple[float, float, float] | None:
    """A disturbance burst's (start s, end s, scale) for the plant; None for another fault or none."""
    if fault is None or fault["kind"] not in PLANT_FAULT_KINDS:
        return None
    return float(fault["start"]), float(fault["start"]) + _duration(fault), float(fault["magnitude"])
