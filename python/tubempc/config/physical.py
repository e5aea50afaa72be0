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
    B. The plates are the plate_* arrays, one entry per plate. The *_dispersion fields are the half-widths of the
    uniform draws a Monte Carlo campaign makes about these values per run; the actuator errors are drawn then too.
    A single run flies these values with error-free actuators."""

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
    # Dispersions (docs/model.md "Dispersions of the physical environment"): each the half-width of a uniform draw
    # about the value above, in its unit, drawn per Monte Carlo run from the run's seed; a single run flies the
    # values above. 0: not dispersed.
    mass_error_dispersion: float = field(
        metadata=number("a campaign run's mass_error is drawn uniformly within mass_error +- this", check=NONNEGATIVE)
    )
    inertia_scale_dispersion: FloatArray = field(
        metadata=number("a campaign run's inertia_scale is drawn uniformly within inertia_scale +- this", (3,), NONNEGATIVE)
    )
    inertia_products_dispersion: FloatArray = field(
        metadata=quantity(
            "moment of inertia",
            "a campaign run's inertia_products are drawn uniformly within inertia_products +- this",
            (3,),
            NONNEGATIVE,
        )
    )
    center_of_mass_dispersion_B: FloatArray = field(
        metadata=quantity(
            "length",
            "a campaign run's centre of mass lies uniformly within +- this (per axis of B) of the nominal one: every "
            "plate_center_B moves by minus the drawn offset",
            (3,),
            NONNEGATIVE,
        )
    )
    plate_specular_dispersion: float = field(
        metadata=number(
            "a campaign run's plate_specular are drawn uniformly within plate_specular +- this, each plate its own",
            check=NONNEGATIVE,
        )
    )
    plate_diffuse_dispersion: float = field(
        metadata=number(
            "a campaign run's plate_diffuse are drawn uniformly within plate_diffuse +- this, each plate its own",
            check=NONNEGATIVE,
        )
    )
    core_density_dispersion: float = field(
        metadata=quantity(
            "density", "a campaign run's core_density is drawn uniformly within core_density +- this", check=NONNEGATIVE
        )
    )
    lobe_density_dispersion: float = field(
        metadata=quantity(
            "density", "a campaign run's lobe_density is drawn uniformly within lobe_density +- this", check=NONNEGATIVE
        )
    )

    @property
    def n_plates(self) -> int:
        """The number of plates."""
        return int(np.asarray(self.plate_area).shape[0])


__all__ = ["PhysicalSection"]
