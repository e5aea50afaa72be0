"""The [physical] section: the truth's physical environment of ``disturbance.model = "physical"`` (docs/model.md
"Physical environment"; tubempc.scenario.physical). A field that sets a member of the C++
``dynamics::PhysicalSettings`` names it (``cpp="mass"``; ``cpp="plates[].area"``: that member of each plate, one
array entry per plate); the body's fields (``core_*``, ``lobe_*``) shape the truth's ``gravity::CompositeGravity``."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .fields import NONNEGATIVE, POSITIVE, boolean, number, quantity
from .sections import FloatArray

_MASS_ERROR = (lambda v: -0.5 < v < 0.5, "in (-0.5, 0.5)")
_INERTIA_SCALE = (lambda v: bool(np.all((np.asarray(v) > 0.5) & (np.asarray(v) < 2.0))), "each in (0.5, 2)")
_COEFFICIENT = (lambda v: bool(np.all((np.asarray(v) >= 0.0) & (np.asarray(v) <= 1.0))), "each in [0, 1]")
_ROWS_NONZERO = (lambda v: bool(np.all(np.linalg.norm(np.asarray(v), axis=1) > 0.0)), "every row non-zero")
_SCALE = (lambda v: 0.0 < v < 1.0, "in (0, 1)")


@dataclass(frozen=True, eq=False)
class PhysicalSection:
    """The truth's physical environment, used with disturbance.model = "physical" (no additive draw): a
    heterogeneous body (the truth's shape, of simulation.truth_shape_subdivisions, with a core and a lobe of
    other densities, its mass the controller's times simulation.density_scale, moved so that its centre of mass
    is the origin), flat-plate solar radiation pressure on the spacecraft's surface, the gravity-gradient
    torque, the truth's mass and inertia, and the actuator errors of disturbance.scale_error_p, ... applied in
    B. The plates are the plate_* arrays, one entry per plate."""

    mass: float = field(
        metadata=quantity(
            "mass",
            "the spacecraft's mass as the controller knows it (the thrust for a commanded acceleration; with an "
            "actuator preset, the preset's mass)",
            check=POSITIVE,
            cpp="mass",
        )
    )
    mass_error: float = field(
        metadata=number("the truth's mass is (1 + mass_error) mass", check=_MASS_ERROR, cpp="mass_error")
    )
    inertia_scale: FloatArray = field(
        metadata=number(
            "the truth's moments of inertia: these multiples of spacecraft.J's diagonal",
            (3,),
            _INERTIA_SCALE,
            cpp="inertia_scale",
        )
    )
    inertia_products: FloatArray = field(
        metadata=quantity(
            "moment of inertia", "[J_xy, J_xz, J_yz] added to the truth's inertia", (3,), cpp="inertia_products"
        )
    )
    srp: bool = field(
        metadata=boolean(
            "flat-plate solar radiation pressure force and torque (the truth's SRP; the controller keeps beta_srp)",
            cpp="srp",
        )
    )
    solar_pressure: float = field(
        metadata=quantity("pressure", "solar radiation pressure at 1 AU", check=NONNEGATIVE, cpp="solar_pressure")
    )
    shadow_radius: float = field(
        metadata=quantity(
            "length",
            "the asteroid's shadow: a cylinder of this radius behind it along +x_L, without SRP (0: no shadow)",
            check=NONNEGATIVE,
            cpp="shadow_radius",
        )
    )
    gravity_gradient: bool = field(
        metadata=boolean("the gravity-gradient torque of the truth body (its G M as a point mass)", cpp="gravity_gradient")
    )
    plate_area: FloatArray = field(metadata=quantity("area", "each plate's area", (-1,), POSITIVE, cpp="plates[].area"))
    plate_normal_B: FloatArray = field(
        metadata=number(
            "each plate's outward normal in B (normalised on use)", (-1, 3), _ROWS_NONZERO, cpp="plates[].normal_B"
        )
    )
    plate_center_B: FloatArray = field(
        metadata=quantity(
            "length", "each plate's centre of pressure from the centre of mass, in B", (-1, 3), cpp="plates[].center_B"
        )
    )
    plate_specular: FloatArray = field(
        metadata=number("each plate's specular reflection coefficient", (-1,), _COEFFICIENT, cpp="plates[].specular")
    )
    plate_diffuse: FloatArray = field(
        metadata=number(
            "each plate's diffuse reflection coefficient (specular + diffuse <= 1)",
            (-1,),
            _COEFFICIENT,
            cpp="plates[].diffuse",
        )
    )
    core_scale: float = field(metadata=number("the core: the truth's shape scaled by this about its centroid", check=_SCALE))
    core_density: float = field(
        metadata=quantity("density", "the core's density minus the body's around it (negative: lighter; 0: no core)")
    )
    lobe_scale: float = field(metadata=number("the lobe: the truth's shape scaled by this", check=_SCALE))
    lobe_center_A: FloatArray = field(
        metadata=quantity("length", "where the lobe's centroid lies in A, from the shape's centroid", (3,))
    )
    lobe_density: float = field(
        metadata=quantity("density", "the lobe's density minus the body's around it (negative: lighter; 0: no lobe)")
    )

    @property
    def n_plates(self) -> int:
        """The number of plates."""
        return int(np.asarray(self.plate_area).shape[0])


__all__ = ["PhysicalSection"]
