"""The [faults] section: faults injected into a run and the navigation step's fault detection (docs/model.md M49-M51,
issue #43; tubempc.scenario.faults). Sensor faults act in the C++ navigation (``nav::SensorFault``), the
disturbance burst in the plant, a thruster or wheel failure in the actuators (also the actuator preset's
``[[faults]]``)."""

from __future__ import annotations

from dataclasses import dataclass, field

from .fields import AT_LEAST_ONE, NONNEGATIVE, NONZERO, POSITIVE, UNIT_INTERVAL, boolean, integer, number, option, quantity
from .sections import FloatArray

#: The sensor fault kinds (``nav::SensorFaultKind``'s names) and the plant's.
SENSOR_FAULT_KINDS: tuple[str, ...] = (
    "camera_outage",
    "landmark_outlier",
    "landmark_mismatch",
    "altimeter_dropout",
    "altimeter_spike",
    "gyro_bias_step",
    "accel_bias_step",
    "gyro_scale_step",
    "accel_scale_step",
    "star_tracker_loss",
)
PLANT_FAULT_KINDS: tuple[str, ...] = ("disturbance_burst",)
#: The actuator faults (spacecraft.actuators other than "ideal"): a thruster (``actuators::FaultKind``) or a wheel.
ACTUATOR_FAULT_KINDS: tuple[str, ...] = ("thruster_failed_off", "thruster_stuck_on", "wheel_failure")
FAULT_KINDS: tuple[str, ...] = SENSOR_FAULT_KINDS + PLANT_FAULT_KINDS + ACTUATOR_FAULT_KINDS

_WINDOW = (lambda v: bool(v.shape == (2,) and 0.0 <= v[0] < v[1]), "0 <= start < end")


@dataclass(frozen=True, eq=False)
class FaultsSection:
    """One fault per run, at a given time (``kind``, ``start``, ``duration``) or, with ``random = true``, drawn per
    run from its seed (a kind of ``random_kinds``, its onset uniform in ``random_window``; ``default_rng([seed,
    43])``); recorded in the run's ``applied`` so that a re-flight flies it again. The size of each kind is its own
    field, in the kind's unit. With navigation, the step's detection (nav/faults.hpp) runs whatever is injected:
    per-sensor NIS tests at a per-sample false-alarm probability, exclusion of a sensor failing ``persistence``
    samples in a row, outages, covariance growth."""

    kind: str = field(metadata=option('the fault injected at start ("none": no fault)', "none", *FAULT_KINDS))
    start: float = field(metadata=quantity("time", "the fault's onset", check=NONNEGATIVE))
    duration: float = field(
        metadata=quantity("time", "how long the fault lasts (0: to the end of the run)", check=NONNEGATIVE)
    )
    random: bool = field(metadata=boolean("draw one fault per run from its seed (kind, start) instead of kind and start"))
    random_kinds: str = field(metadata=option("the kinds a random fault is drawn from, comma-separated"))
    random_window: FloatArray = field(metadata=quantity("time", "[earliest, latest] onset of a random fault", (2,), _WINDOW))
    landmark_outlier_px: float = field(
        metadata=number("landmark_outlier: the first landmark of each frame shifted along u by this many pixels")
    )
    altimeter_spike: float = field(metadata=quantity("length", "altimeter_spike: added to the measured range"))
    gyro_bias_step: float = field(metadata=quantity("angular velocity", "gyro_bias_step: added to the gyro's rate"))
    accel_bias_step: float = field(
        metadata=quantity("acceleration", "accel_bias_step: added to the accelerometer's specific force")
    )
    imu_scale_step: float = field(
        metadata=number("gyro_scale_step, accel_scale_step: the measurement is multiplied by 1 + this")
    )
    bias_axis_B: FloatArray = field(metadata=number("the direction in B of a bias step (normalised)", (3,), NONZERO))
    actuator_index: int = field(
        metadata=integer(
            "thruster_failed_off, thruster_stuck_on, wheel_failure: the thruster or wheel that fails (-1: drawn per run)",
            (lambda v: v >= -1, ">= -1"),
        )
    )
    burst_scale: float = field(
        metadata=number(
            "disturbance_burst: the drawn disturbance is multiplied by this (beyond the identified set)", check=POSITIVE
        )
    )
    detection: bool = field(metadata=boolean("the navigation step's fault detection (nav::FaultDetectionSettings)"))
    exclude: bool = field(metadata=boolean("a sensor declared faulty is no longer folded in"))
    false_alarm_probability: float = field(
        metadata=number(
            "probability that a fault-free sample fails its NIS test (the chi-square quantile of 1 - this)",
            check=UNIT_INTERVAL,
        )
    )
    persistence: int = field(metadata=integer("failed samples in a row that declare a sensor faulty", AT_LEAST_ONE))
    outage_time: float = field(
        metadata=quantity("time", "longest time without a good sample before an outage is declared", check=POSITIVE)
    )
    max_position_sigma: float = field(
        metadata=quantity("length", "bound on the position's standard deviation sqrt(trace P_rr)", check=POSITIVE)
    )

    @property
    def random_kind_list(self) -> tuple[str, ...]:
        """``random_kinds`` split at its commas."""
        return tuple(k.strip() for k in self.random_kinds.split(",") if k.strip())
