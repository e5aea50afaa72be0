"""The [navigation] section. A field that sets a member of the C++ ``nav::NavigationSettings`` names it
(``cpp="camera.min_range"``): tubempc.scenario.navigation sets every such member from its field, and
the filter's copies of the sensors from the sensors."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .. import _core
from .fields import AT_LEAST_ONE, HALF_TURN, NONNEGATIVE, NONZERO, POSITIVE, boolean, integer, number, option, quantity
from .sections import FloatArray

_PROBABILITY = (lambda v: 0.0 <= v <= 1.0, "in [0, 1]")
_OPEN_PROBABILITY = (lambda v: 0.0 < v < 1.0, "in (0, 1)")
_RIGHT_ANGLE = (lambda v: 0.0 < v <= math.pi / 2, "in (0, 90] deg")
_FRAME_CAPACITY = (
    lambda v: 1 <= v <= _core.nav.MAX_LANDMARKS_PER_FRAME,
    f"in [1, {_core.nav.MAX_LANDMARKS_PER_FRAME}] (nav::kMaxLandmarksPerFrame)",
)


@dataclass(frozen=True, eq=False)
class NavigationSection:
    """Navigation in the loop (docs/model.md "Navigation", "Output-feedback tube";
    tubempc.scenario.navigation). enabled = false: the controller reads the true state, as the paper's.
    true: the plant is propagated in sub-steps of imu_period, the sensors sample it at their periods
    (each an integer multiple of imu_period, as mpc.dt is), the filter's estimate is what the controller
    flies on, and the state constraints are also tightened by the estimation-error set (a probabilistic
    bound). The sensors' noise is also the filter's model of it. A file that leaves out
    altimeter_boresight_B or camera_boresight_B gets spacecraft.boresight_B (``BORESIGHT_DEFAULTS``).
    Seeded from the run's seed."""

    enabled: bool = field(metadata=boolean("the controller flies on the filter's estimate (false: on the true state)"))
    imu_period: float = field(
        metadata=quantity(
            "time", "the IMU's period, the sub-step of the plant's propagation", check=POSITIVE, cpp="imu.period"
        )
    )
    gyro_noise_density: float = field(
        metadata=quantity("angle random walk", "gyro noise density", check=NONNEGATIVE, cpp="imu.gyro_noise_density")
    )
    gyro_bias_sigma: float = field(
        metadata=quantity("angular velocity", "gyro bias, initial sigma", check=NONNEGATIVE, cpp="imu.gyro_bias_sigma")
    )
    gyro_bias_random_walk: float = field(
        metadata=quantity("rate random walk", "gyro bias random walk", check=NONNEGATIVE, cpp="imu.gyro_bias_random_walk")
    )
    accel_noise_density: float = field(
        metadata=quantity(
            "velocity random walk", "accelerometer noise density", check=NONNEGATIVE, cpp="imu.accel_noise_density"
        )
    )
    accel_bias_sigma: float = field(
        metadata=quantity("acceleration", "accelerometer bias, initial sigma", check=NONNEGATIVE, cpp="imu.accel_bias_sigma")
    )
    accel_bias_random_walk: float = field(
        metadata=quantity(
            "acceleration random walk",
            "accelerometer bias random walk",
            check=NONNEGATIVE,
            cpp="imu.accel_bias_random_walk",
        )
    )
    imu_dropout: float = field(
        metadata=number("probability that an IMU sample is lost", check=_PROBABILITY, cpp="imu.dropout_probability")
    )
    altimeter_boresight_B: FloatArray = field(
        metadata=number("the laser altimeter's beam in B", (3,), NONZERO, cpp="altimeter.boresight_B")
    )
    altimeter_period: float = field(
        metadata=quantity("time", "the altimeter's period", check=POSITIVE, cpp="altimeter.period")
    )
    altimeter_sigma: float = field(
        metadata=quantity("length", "the altimeter's range noise", check=NONNEGATIVE, cpp="altimeter.sigma")
    )
    altimeter_bias: float = field(
        metadata=quantity("length", "the altimeter's calibrated range bias (the filter subtracts it)", cpp="altimeter.bias")
    )
    altimeter_min_range: float = field(
        metadata=quantity("length", "the altimeter's shortest range", check=NONNEGATIVE, cpp="altimeter.min_range")
    )
    altimeter_max_range: float = field(
        metadata=quantity("length", "the altimeter's longest range", check=POSITIVE, cpp="altimeter.max_range")
    )
    altimeter_dropout: float = field(
        metadata=number(
            "probability that an altimeter sample is lost", check=_PROBABILITY, cpp="altimeter.dropout_probability"
        )
    )
    camera_boresight_B: FloatArray = field(
        metadata=number("the navigation camera's optical axis in B (its z_C)", (3,), NONZERO)
    )
    camera_period: float = field(metadata=quantity("time", "the camera's period", check=POSITIVE, cpp="camera.period"))
    camera_fov: float = field(metadata=quantity("angle", "full field of view of the square image", check=HALF_TURN))
    camera_pixels: int = field(metadata=integer("image width and height in pixels", check=AT_LEAST_ONE))
    camera_pixel_sigma: float = field(
        metadata=number("landmark centroid noise in pixels", check=POSITIVE, cpp="camera.pixel_sigma")
    )
    camera_max_emission_angle: float = field(
        metadata=quantity(
            "angle",
            "largest angle between a seen landmark's normal and the line of sight",
            check=_RIGHT_ANGLE,
            cpp="camera.max_emission_angle",
        )
    )
    camera_max_incidence_angle: float = field(
        metadata=quantity(
            "angle",
            "largest angle between a seen landmark's normal and the Sun",
            check=(lambda v: 0.0 < v <= math.pi, "in (0, 180] deg"),
            cpp="camera.max_incidence_angle",
        )
    )
    camera_min_range: float = field(
        metadata=quantity("length", "the camera's shortest range", check=NONNEGATIVE, cpp="camera.min_range")
    )
    camera_max_range: float = field(
        metadata=quantity("length", "the camera's longest range", check=POSITIVE, cpp="camera.max_range")
    )
    camera_max_landmarks: int = field(
        metadata=integer("most landmarks measured in one frame", check=_FRAME_CAPACITY, cpp="camera.max_landmarks")
    )
    camera_dropout: float = field(
        metadata=number("probability that a camera frame is lost", check=_PROBABILITY, cpp="camera.dropout_probability")
    )
    landmarks: int = field(
        metadata=integer("catalogue landmarks spread over the body (a Fibonacci lattice of directions)", check=AT_LEAST_ONE)
    )
    site_landmarks: int = field(
        metadata=integer("catalogue landmarks on a disc about the landing site (a site map)", check=NONNEGATIVE)
    )
    site_landmark_radius: float = field(metadata=quantity("length", "radius of the site landmarks' disc", check=POSITIVE))
    star_tracker_period: float = field(
        metadata=quantity("time", "the star tracker's period", check=POSITIVE, cpp="star_tracker.period")
    )
    star_tracker_sigma_B: FloatArray = field(
        metadata=quantity(
            "angle", "the star tracker's attitude noise about the B axes", (3,), NONNEGATIVE, cpp="star_tracker.sigma_B"
        )
    )
    star_tracker_dropout: float = field(
        metadata=number(
            "probability that a star tracker sample is lost", check=_PROBABILITY, cpp="star_tracker.dropout_probability"
        )
    )
    altimeter_terrain_sigma: float = field(
        metadata=quantity(
            "length",
            "the filter's allowance for the faceted terrain",
            check=NONNEGATIVE,
            cpp="filter.altimeter_terrain_sigma",
        )
    )
    accel_model_noise: float = field(
        metadata=quantity(
            "velocity random walk",
            "the filter's allowance for unmodelled forces",
            check=NONNEGATIVE,
            cpp="filter.accel_model_noise",
        )
    )
    innovation_gate: float = field(
        metadata=number("largest NIS of one accepted measurement", check=POSITIVE, cpp="filter.innovation_gate")
    )
    gravity_relinearization_distance: float = field(
        metadata=quantity(
            "length",
            "the filter's gravity expansion is held at least this far from its point",
            check=NONNEGATIVE,
            cpp="filter.gravity_relinearization_distance",
        )
    )
    gravity_expansion_tolerance: float = field(
        metadata=quantity(
            "acceleration",
            "the expansion is also held while its predicted error stays below this (M42)",
            check=NONNEGATIVE,
            cpp="filter.gravity_expansion_tolerance",
        )
    )
    covariance_step: float = field(
        metadata=quantity(
            "time",
            "longest span the covariance waits for its propagation (0: every IMU sample)",
            check=NONNEGATIVE,
            cpp="filter.covariance_step",
        )
    )
    initial_sigma_position: float = field(
        metadata=quantity("length", "initial estimation error of the position, per axis", check=NONNEGATIVE)
    )
    initial_sigma_velocity: float = field(
        metadata=quantity("velocity", "initial estimation error of the velocity, per axis", check=NONNEGATIVE)
    )
    initial_sigma_attitude: float = field(
        metadata=quantity("angle", "initial estimation error of the attitude, per axis", check=NONNEGATIVE)
    )
    period_noise: str = field(
        metadata=option(
            'the filter\'s model of the per-period disturbance: "disturbance" (the covariance of what of the '
            "[disturbance] draw no sensor senses as the plant delivers it, at its largest growth, times "
            'period_noise_scale^2, added at each period\'s end; docs/model.md M39) or "none"',
            "disturbance",
            "none",
        )
    )
    period_noise_scale: float = field(metadata=number("scale of the period noise's sigmas", check=NONNEGATIVE))
    error_set_probability: float = field(
        metadata=number(
            "probability of the estimation-error set, the chi-square ellipsoid of the filter's covariance (12 dof)",
            check=_OPEN_PROBABILITY,
        )
    )
