"""The truth's physical environment of ``disturbance.model = "physical"`` (docs/model.md "Physical environment";
docs/decisions.md "A physical disturbance environment"): one typed description, :class:`PhysicalTruth`, built
once per scenario from the configuration's ``[physical]`` section and kept on the scenario
(``Scenario.physical``), from which the C++ plant's objects are made (the truth body's
``_core.gravity.CompositeGravity``, a run's ``_core.dynamics.PhysicalEnvironment``) and which another plant (a
Basilisk one) maps term by term: the body's parts with their densities and offsets, G M, the spacecraft's plates,
its true mass and inertia, and which torques are on.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..config import Config
from ..models.disturbances import ActuatorMismatch
from .shapes import Shape
from .sites import inside

__all__ = ["BodyPart", "PhysicalConfigError", "PhysicalTruth", "Plate", "physical_settings", "physical_truth"]

Array = npt.NDArray[np.float64]


class PhysicalConfigError(ValueError):
    """A [physical] section the scenario cannot fly (the message names the field)."""


@dataclass(frozen=True, eq=False)
class BodyPart:
    """One homogeneous part of the truth body: the mesh ``shape`` (m, in its own coordinates), placed so that its
    point p lies at p + ``offset_A`` in the body frame A (the truth's centre of mass is the origin), of density
    ``density`` (kg/m^3; negative for a deficit inside another part). ``name``: "body", "core" or "lobe"."""

    name: str
    shape: Shape
    density: float
    offset_A: Array

    @property
    def mass(self) -> float:
        """The part's (signed) mass, density times volume (kg)."""
        return self.density * float(self.shape.volume)


@dataclass(frozen=True, eq=False)
class Plate:
    """One flat plate of the spacecraft's surface, fixed in B: ``area`` (m^2), unit outward ``normal_B``,
    ``center_B`` the centre of pressure from the centre of mass (m, in B), ``specular`` and ``diffuse``
    reflection coefficients."""

    area: float
    normal_B: Array
    center_B: Array
    specular: float
    diffuse: float


@dataclass(frozen=True, eq=False)
class PhysicalTruth:
    """The truth's physical environment (every quantity SI, frames as docs/model.md "Frames").

    The body: ``parts`` (the truth's shape at its base density, a core and a lobe of other densities), their sum
    the truth's gravity; ``center_of_mass_offset_A`` the heterogeneous body's centre of mass from the shape's
    centroid (the controller's origin), removed from every part's offset so that the truth's centre of mass is
    the origin: the controller's homogeneous body lies displaced by this vector from the truth's. ``gm`` and
    ``mass`` are the truth body's (``mass`` = the controller's body's times simulation.density_scale).

    The spacecraft: the controller's ``mass_model`` and ``inertia_model_B``, the truth's ``mass_true`` and
    ``inertia_true_B``; ``plates``; the solar radiation pressure ``solar_pressure`` at 1 AU and ``pressure`` at
    the asteroid's distance; ``shadow_radius``; ``srp`` and ``gravity_gradient`` (whether each is on); the
    actuator errors' bounds ``actuator_error_bounds`` (disturbance.scale_error_p, misalignment_p, scale_error_r,
    misalignment_r), drawn per run (:meth:`actuator_errors`).
    """

    parts: tuple[BodyPart, ...]
    center_of_mass_offset_A: Array
    gm: float
    mass: float
    mass_model: float
    mass_true: float
    inertia_model_B: Array
    inertia_true_B: Array
    plates: tuple[Plate, ...]
    solar_pressure: float
    pressure: float
    orbit_radius: float
    shadow_radius: float
    srp: bool
    gravity_gradient: bool
    actuator_error_bounds: dict[str, float]
    #: The scalar fields of ``dynamics::PhysicalSettings`` by name (the [physical] fields of the same names).
    settings_fields: dict[str, Any]

    def settings(self) -> Any:
        """The C++ settings (``_core.dynamics.PhysicalSettings``) of this description (plain data, so that the
        description pickles)."""
        s = _core.dynamics.PhysicalSettings()
        for name, value in self.settings_fields.items():
            setattr(s, name, value)
        plates = []
        for p in self.plates:
            plate = _core.dynamics.FlatPlate()
            plate.area, plate.normal_B, plate.center_B = p.area, p.normal_B, p.center_B
            plate.specular, plate.diffuse = p.specular, p.diffuse
            plates.append(plate)
        s.plates = plates
        return s

    def gravity(self) -> Any:
        """The truth body's field (``_core.gravity.CompositeGravity``), its centre of mass at the origin."""
        return _core.gravity.CompositeGravity([(p.shape, p.density, p.offset_A) for p in self.parts])

    def actuator_errors(self, seed: int) -> tuple[Array, Array, dict[str, Any]]:
        """A run's thrust and torque error matrices in B (E_F, E_T) and their description: drawn as the drawn
        model's actuator mismatch (``ActuatorMismatch`` from ``seed + 1``), applied in B."""
        b = self.actuator_error_bounds
        m = ActuatorMismatch(seed + 1, b["scale_error_p"], b["misalignment_p"], b["scale_error_r"], b["misalignment_r"])
        return m.M_p, m.M_r, {**m.describe(), "frame": "B"}

    def environment(self, seed: int) -> Any:
        """A run's C++ environment (``_core.dynamics.PhysicalEnvironment``) with its actuator errors."""
        E_F, E_T, _ = self.actuator_errors(seed)
        return _core.dynamics.PhysicalEnvironment(
            self.settings(), self.inertia_model_B, self.gm, self.orbit_radius, E_F, E_T
        )

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary (what a run record keeps): the parts without their meshes, the spacecraft, the
        terms."""
        return {
            "model": "physical",
            "parts": [
                {
                    "name": p.name,
                    "density": p.density,
                    "offset_A": p.offset_A.tolist(),
                    "volume": float(p.shape.volume),
                    "faces": int(p.shape.n_faces),
                }
                for p in self.parts
            ],
            "center_of_mass_offset_A": self.center_of_mass_offset_A.tolist(),
            "gm": self.gm,
            "mass": self.mass,
            "mass_model": self.mass_model,
            "mass_true": self.mass_true,
            "inertia_model_B": self.inertia_model_B.tolist(),
            "inertia_true_B": self.inertia_true_B.tolist(),
            "plates": [
                {
                    "area": p.area,
                    "normal_B": p.normal_B.tolist(),
                    "center_B": p.center_B.tolist(),
                    "specular": p.specular,
                    "diffuse": p.diffuse,
                }
                for p in self.plates
            ],
            "solar_pressure": self.solar_pressure,
            "pressure": self.pressure,
            "shadow_radius": self.shadow_radius,
            "srp": self.srp,
            "gravity_gradient": self.gravity_gradient,
            "actuator_error_bounds": dict(self.actuator_error_bounds),
        }


def physical_settings(cfg: Config) -> Any:
    """The C++ ``dynamics::PhysicalSettings`` of the ``[physical]`` section: every field that names a member
    (``Spec.cpp``) sets it, a ``plates[].member`` field that member of each plate."""
    from dataclasses import fields

    p = cfg.physical
    s = _core.dynamics.PhysicalSettings()
    plates = [_core.dynamics.FlatPlate() for _ in range(p.n_plates)]
    for f in fields(p):
        target = f.metadata["spec"].cpp
        if target is None:
            continue
        value = getattr(p, f.name)
        if target.startswith("plates[]."):
            member = target.removeprefix("plates[].")
            for plate, v in zip(plates, np.asarray(value, dtype=float), strict=True):
                setattr(plate, member, v if np.ndim(v) else float(v))
        else:
            setattr(s, target, np.asarray(value, dtype=float) if np.ndim(value) else value)
    s.plates = plates
    return s


def _scaled(shape: Shape, factor: float) -> Shape:
    """The shape scaled by ``factor`` about its centroid, in coordinates centred on it."""
    v = np.asarray(shape.vertices)
    c = np.asarray(shape.center_of_mass)
    return Shape((v - c) * factor, np.asarray(shape.faces))


def physical_truth(cfg: Config, controller_body: Any, truth_shape: Shape) -> PhysicalTruth:
    """The truth's physical environment of ``cfg`` (its ``[physical]`` section): the truth body on
    ``truth_shape`` (m, A, centroid at the origin) whose mass is the ``controller_body``'s (a
    ``PolyhedronGravity``) times simulation.density_scale, and the spacecraft of mass physical.mass and inertia
    spacecraft.J as the controller knows them. PhysicalConfigError naming the field for a core or lobe outside
    the body, a region of non-positive density, or a truth inertia that is no inertia tensor."""
    p, src = cfg.physical, cfg.source
    inertia_model_B = np.asarray(cfg.spacecraft.J, dtype=float)
    target_mass = float(controller_body.mass) * cfg.simulation.density_scale
    regions: list[tuple[str, Shape, float, Array]] = []
    for name, scale, density, center in (
        ("core", p.core_scale, p.core_density, np.zeros(3)),
        ("lobe", p.lobe_scale, p.lobe_density, np.asarray(p.lobe_center_A, dtype=float)),
    ):
        if density == 0.0:
            continue
        part = _scaled(truth_shape, scale)
        placed = np.asarray(part.vertices) + center
        outside = ~inside(truth_shape, placed)
        if np.any(outside):
            worst = placed[outside][np.argmax(np.linalg.norm(placed[outside], axis=1))]
            raise PhysicalConfigError(
                f"{src}: physical.{name}_scale: the {name} ({name}_scale = {scale:g}"
                + (f", lobe_center_A = {center.tolist()} m" if name == "lobe" else "")
                + f") reaches outside the body ({int(outside.sum())} of its vertices, e.g. {np.round(worst, 2).tolist()} m)"
            )
        regions.append((name, part, float(density), center))
    contrast_mass = sum(d * float(s.volume) for _, s, d, _ in regions)
    base_density = (target_mass - contrast_mass) / float(truth_shape.volume)
    lowest = base_density + sum(min(d, 0.0) for _, _, d, _ in regions)
    if not lowest > 0.0:
        raise PhysicalConfigError(
            f"{src}: physical.core_density, lobe_density: the body's density around the core and the lobe would be "
            f"{base_density:.4g} kg/m^3 and the lightest region's {lowest:.4g} kg/m^3; every region needs a positive density"
        )
    parts = [("body", truth_shape, base_density, np.zeros(3)), *regions]
    unshifted = _core.gravity.CompositeGravity([(s, d, o) for _, s, d, o in parts])
    com = np.asarray(unshifted.center_of_mass, dtype=float)
    body_parts = tuple(BodyPart(name, s, d, np.asarray(o, dtype=float) - com) for name, s, d, o in parts)
    settings = physical_settings(cfg)
    try:
        settings.validate()
        inertia_true = np.asarray(settings.true_inertia(inertia_model_B))
    except ValueError as exc:
        name = "inertia_scale" if "inertia_scale" in str(exc) else "inertia_products"
        raise PhysicalConfigError(f"{src}: physical.{name}: {exc} (spacecraft.J is the controller's)") from exc
    au_r = _core.dynamics.ASTRONOMICAL_UNIT / cfg.environment.R
    d = cfg.disturbance
    return PhysicalTruth(
        parts=body_parts,
        center_of_mass_offset_A=com,
        gm=float(unshifted.gm),
        mass=float(unshifted.mass),
        mass_model=p.mass,
        mass_true=float(settings.true_mass()),
        inertia_model_B=inertia_model_B,
        inertia_true_B=inertia_true,
        plates=tuple(
            Plate(
                float(a),
                np.asarray(n, dtype=float) / float(np.linalg.norm(n)),
                np.asarray(c, dtype=float),
                float(rs),
                float(rd),
            )
            for a, n, c, rs, rd in zip(
                p.plate_area, p.plate_normal_B, p.plate_center_B, p.plate_specular, p.plate_diffuse, strict=True
            )
        ),
        solar_pressure=p.solar_pressure,
        pressure=p.solar_pressure * au_r * au_r,
        orbit_radius=cfg.environment.R,
        shadow_radius=p.shadow_radius,
        srp=p.srp,
        gravity_gradient=p.gravity_gradient,
        actuator_error_bounds={
            "scale_error_p": d.scale_error_p,
            "misalignment_p": d.misalignment_p,
            "scale_error_r": d.scale_error_r,
            "misalignment_r": d.misalignment_r,
        },
        settings_fields={name: getattr(settings, name) for name in _core.dynamics.PhysicalSettings.field_names()},
    )
