"""The truth's physical environment of ``disturbance.model = "physical"`` (docs/model.md "Physical environment";
docs/decisions.md "A physical disturbance environment"): one typed description, :class:`PhysicalTruth`, built
once per scenario from the configuration's ``[physical]`` section and kept on the scenario
(``Scenario.physical``), from which the C++ plant's objects are made (the truth body's
``_core.gravity.CompositeGravity``, a run's ``_core.dynamics.PhysicalEnvironment``) and which another plant (a
Basilisk one) maps term by term: the body's parts with their densities and offsets, G M, the spacecraft's plates,
its true mass and inertia, and which torques are on.

The description a scenario keeps is the nominal truth, which a single run flies. A Monte Carlo campaign's run
flies :meth:`PhysicalTruth.dispersed`: the truth's uncertain parameters (the body's density contrasts, the
spacecraft's mass, inertia and centre of mass, the plates' reflection coefficients, the actuators' scale and
misalignment errors) drawn from the run's seed within the ``[physical]`` section's ``*_dispersion`` half-widths
(docs/model.md "Dispersions of the physical environment").
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..config import Config
from ..models.disturbances import ActuatorMismatch
from .shapes import Shape
from .sites import inside

__all__ = [
    "DISPERSION_STREAM",
    "BodyPart",
    "PhysicalConfigError",
    "PhysicalDispersion",
    "PhysicalTruth",
    "Plate",
    "Region",
    "physical_settings",
    "physical_truth",
]

Array = npt.NDArray[np.float64]

#: A run's physical dispersions are drawn from ``numpy.random.default_rng([seed, DISPERSION_STREAM])``: a stream
#: of their own beside the drawn disturbance's (``seed``), the actuator errors' (``seed + 1``, as the drawn
#: model's) and the navigation's (``seed + NAV_SEED_OFFSET``).
DISPERSION_STREAM = 40


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
class Region:
    """A region of the truth body of another density (the core or the lobe): ``shape`` (m, centred on its centroid)
    placed with its centroid at ``center_A`` from the truth shape's centroid, of density contrast ``density``
    (kg/m^3) over the body around it. A scenario keeps a region whose contrast is 0 but dispersed: a campaign
    run draws one."""

    name: str
    shape: Shape
    density: float
    center_A: Array


@dataclass(frozen=True, eq=False)
class PhysicalDispersion:
    """The half-widths of a campaign run's uniform draws about the nominal truth (the ``[physical]`` section's
    ``*_dispersion`` fields, SI): the mass error, the inertia's scale factors and products (kg m^2), the centre of
    mass in B (m, per axis), the plates' specular and diffuse coefficients (each plate its own draw) and the
    core's and lobe's density contrasts (kg/m^3)."""

    mass_error: float
    inertia_scale: Array
    inertia_products: Array
    center_of_mass_B: Array
    plate_specular: float
    plate_diffuse: float
    core_density: float
    lobe_density: float

    def describe(self) -> dict[str, Any]:
        """JSON-ready half-widths, by the name of the ``[physical]`` field each widens."""
        return {
            "mass_error": self.mass_error,
            "inertia_scale": np.asarray(self.inertia_scale).tolist(),
            "inertia_products": np.asarray(self.inertia_products).tolist(),
            "center_of_mass_B": np.asarray(self.center_of_mass_B).tolist(),
            "plate_specular": self.plate_specular,
            "plate_diffuse": self.plate_diffuse,
            "core_density": self.core_density,
            "lobe_density": self.lobe_density,
        }


@dataclass(frozen=True, eq=False)
class PhysicalTruth:
    """The truth's physical environment (every quantity SI, frames as docs/model.md "Frames").

    The body: ``parts`` (the truth's shape at its base density, a core and a lobe of other densities), their sum
    the truth's gravity; ``center_of_mass_offset_A`` the heterogeneous body's centre of mass from the shape's
    centroid (the controller's origin), removed from every part's offset so that the truth's centre of mass is
    the origin: the controller's homogeneous body lies displaced by this vector from the truth's. ``gm`` and
    ``mass`` are the truth body's (``mass`` = the controller's body's times simulation.density_scale).
    ``regions``: the core and the lobe as configured (with a contrast, or a dispersed one), from which a
    dispersed run's body is rebuilt.

    The spacecraft: the controller's ``mass_model`` and ``inertia_model_B``, the truth's ``mass_true`` and
    ``inertia_true_B``; ``plates``; the solar radiation pressure ``solar_pressure`` at 1 AU and ``pressure`` at
    the asteroid's distance; ``shadow_radius``; ``srp`` and ``gravity_gradient`` (whether each is on); the
    actuators' error matrices in B, ``thrust_error_B`` and ``torque_error_B`` (the nominal's: none), with their
    description ``actuators`` and the bounds of a run's draw ``actuator_error_bounds`` (disturbance.scale_error_p,
    misalignment_p, scale_error_r, misalignment_r).

    ``dispersion``: the half-widths of a campaign run's draws; ``drawn``: what :meth:`dispersed` drew (None: the
    nominal truth, which a scenario keeps and a single run flies).
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
    regions: tuple[Region, ...]
    #: The body's mass as configured (kg): the controller's body's times simulation.density_scale (``mass`` is the
    #: sum of the parts', equal to it to rounding), which a dispersed body keeps.
    target_mass: float
    dispersion: PhysicalDispersion
    thrust_error_B: Array
    torque_error_B: Array
    actuators: dict[str, Any]
    drawn: dict[str, Any] | None = None

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

    def environment(self) -> Any:
        """The C++ environment (``_core.dynamics.PhysicalEnvironment``) of this truth, with its actuator errors."""
        return _core.dynamics.PhysicalEnvironment(
            self.settings(), self.inertia_model_B, self.gm, self.orbit_radius, self.thrust_error_B, self.torque_error_B
        )

    def dispersed(self, seed: int) -> PhysicalTruth:
        """The truth of a campaign's run with seed ``seed``: every parameter of :attr:`dispersion` drawn uniformly
        within its nominal +- half-width from ``numpy.random.default_rng([seed, DISPERSION_STREAM])`` (in a fixed
        order, each drawn whatever its half-width, so that widening one leaves the others' draws), and the
        actuators' errors drawn as the drawn model's actuator mismatch (``ActuatorMismatch`` from ``seed + 1``),
        applied in B. The body is rebuilt with the drawn contrasts (its mass kept, its centre of mass moved to the
        origin again); the plates' centres move by minus the drawn centre-of-mass offset. Deterministic: the same
        seed gives the same truth to the bit."""
        d, n = self.dispersion, len(self.plates)
        rng = np.random.default_rng([int(seed), DISPERSION_STREAM])
        u_mass = float(rng.uniform(-1.0, 1.0))
        u_scale, u_products, u_com = rng.uniform(-1.0, 1.0, 3), rng.uniform(-1.0, 1.0, 3), rng.uniform(-1.0, 1.0, 3)
        u_specular, u_diffuse = rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n)
        u_core, u_lobe = (float(v) for v in rng.uniform(-1.0, 1.0, 2))
        f = self.settings_fields
        mass_error = float(f["mass_error"]) + d.mass_error * u_mass
        inertia_scale = np.asarray(f["inertia_scale"], dtype=float) + np.asarray(d.inertia_scale) * u_scale
        inertia_products = np.asarray(f["inertia_products"], dtype=float) + np.asarray(d.inertia_products) * u_products
        com_B = np.asarray(d.center_of_mass_B) * u_com
        plates = tuple(
            Plate(
                p.area,
                p.normal_B,
                p.center_B - com_B,
                p.specular + d.plate_specular * float(us),
                p.diffuse + d.plate_diffuse * float(ud),
            )
            for p, us, ud in zip(self.plates, u_specular, u_diffuse, strict=True)
        )
        contrasts = {"core": (d.core_density, u_core), "lobe": (d.lobe_density, u_lobe)}
        regions = tuple(
            Region(r.name, r.shape, r.density + contrasts[r.name][0] * contrasts[r.name][1], r.center_A)
            for r in self.regions
        )
        body = _body(self.parts[0].shape, regions, self.target_mass)
        fields = {**f, "mass_error": mass_error, "inertia_scale": inertia_scale, "inertia_products": inertia_products}
        settings = _core.dynamics.PhysicalSettings()
        for name, value in fields.items():
            setattr(settings, name, value)
        b = self.actuator_error_bounds
        m = ActuatorMismatch(seed + 1, b["scale_error_p"], b["misalignment_p"], b["scale_error_r"], b["misalignment_r"])
        drawn = {
            "seed": int(seed),
            "stream": [int(seed), DISPERSION_STREAM],
            "mass_error": mass_error,
            "inertia_scale": inertia_scale.tolist(),
            "inertia_products": inertia_products.tolist(),
            "center_of_mass_B": com_B.tolist(),
            "plate_specular": [p.specular for p in plates],
            "plate_diffuse": [p.diffuse for p in plates],
            "core_density": next((r.density for r in regions if r.name == "core"), 0.0),
            "lobe_density": next((r.density for r in regions if r.name == "lobe"), 0.0),
        }
        return replace(
            self,
            parts=body.parts,
            center_of_mass_offset_A=body.center_of_mass_offset_A,
            gm=body.gm,
            mass=body.mass,
            mass_true=float(settings.true_mass()),
            inertia_true_B=np.asarray(settings.true_inertia(self.inertia_model_B), dtype=float),
            plates=plates,
            settings_fields=fields,
            thrust_error_B=m.M_p,
            torque_error_B=m.M_r,
            actuators={**m.describe(), "frame": "B"},
            drawn=drawn,
        )

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary (what a run record keeps): the parts without their meshes, the spacecraft, the
        terms, the dispersions' half-widths and, for a dispersed run, what it drew."""
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
            "dispersion": self.dispersion.describe(),
            "drawn": self.drawn,
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


@dataclass(frozen=True)
class _Body:
    parts: tuple[BodyPart, ...]
    center_of_mass_offset_A: Array
    gm: float
    mass: float


def _base_density(truth_shape: Shape, regions: tuple[Region, ...], target_mass: float) -> tuple[float, float]:
    """The body's density around the regions that makes its mass ``target_mass``, and the lightest region's
    density (the base plus every negative contrast: a lower bound where regions overlap)."""
    contrast_mass = sum(r.density * float(r.shape.volume) for r in regions)
    base = (target_mass - contrast_mass) / float(truth_shape.volume)
    return base, base + sum(min(r.density, 0.0) for r in regions)


def _body(truth_shape: Shape, regions: tuple[Region, ...], target_mass: float) -> _Body:
    """The heterogeneous body of mass ``target_mass``: the truth's shape at the base density and each region of a
    non-zero contrast, every part moved so that the centre of mass is the origin."""
    present = tuple(r for r in regions if r.density != 0.0)
    base, _ = _base_density(truth_shape, present, target_mass)
    parts = [("body", truth_shape, base, np.zeros(3)), *((r.name, r.shape, r.density, r.center_A) for r in present)]
    unshifted = _core.gravity.CompositeGravity([(s, d, o) for _, s, d, o in parts])
    com = np.asarray(unshifted.center_of_mass, dtype=float)
    return _Body(
        tuple(BodyPart(name, s, d, np.asarray(o, dtype=float) - com) for name, s, d, o in parts),
        com,
        float(unshifted.gm),
        float(unshifted.mass),
    )


def _dispersion(cfg: Config) -> PhysicalDispersion:
    p = cfg.physical
    return PhysicalDispersion(
        mass_error=p.mass_error_dispersion,
        inertia_scale=np.asarray(p.inertia_scale_dispersion, dtype=float),
        inertia_products=np.asarray(p.inertia_products_dispersion, dtype=float),
        center_of_mass_B=np.asarray(p.center_of_mass_dispersion_B, dtype=float),
        plate_specular=p.plate_specular_dispersion,
        plate_diffuse=p.plate_diffuse_dispersion,
        core_density=p.core_density_dispersion,
        lobe_density=p.lobe_density_dispersion,
    )


def _check_density_range(
    src: str, truth_shape: Shape, regions: tuple[Region, ...], d: PhysicalDispersion, target_mass: float
) -> None:
    """Every region's density positive over the contrasts' dispersions: the lightest region's density is concave
    in the contrasts (a minimum of linear functions), so its corners bound it."""
    half = {"core": d.core_density, "lobe": d.lobe_density}
    if not any(half[r.name] > 0.0 for r in regions):
        return
    for signs in itertools.product((-1.0, 1.0), repeat=len(regions)):
        corner = tuple(
            Region(r.name, r.shape, r.density + s * half[r.name], r.center_A) for r, s in zip(regions, signs, strict=True)
        )
        base, lowest = _base_density(truth_shape, corner, target_mass)
        if not lowest > 0.0:
            contrasts = ", ".join(f"{r.name}_density {r.density:g} kg/m^3" for r in corner)
            raise PhysicalConfigError(
                f"{src}: physical.core_density_dispersion, lobe_density_dispersion: at {contrasts} (a corner of the "
                f"dispersions) the body's density around the core and the lobe would be {base:.4g} kg/m^3 and the "
                f"lightest region's {lowest:.4g} kg/m^3; every region needs a positive density"
            )


def _check_inertia_range(src: str, settings: Any, inertia_model_B: Array, d: PhysicalDispersion) -> None:
    """The truth's inertia is an inertia tensor over the dispersions of its scale factors and products: positive
    definite and obeying the triangle inequality are linear matrix inequalities in them (J > 0, tr(J)/2 I - J >= 0),
    so the box's corners bound it. ``settings``: a copy of the section's, which this changes."""
    widths = np.concatenate([np.asarray(d.inertia_scale), np.asarray(d.inertia_products)])
    if not np.any(widths > 0.0):
        return
    scale0 = np.array(settings.inertia_scale, dtype=float)  # copies: the bindings return views of the settings
    products0 = np.array(settings.inertia_products, dtype=float)
    for signs in itertools.product((-1.0, 1.0), repeat=6):
        corner = np.asarray(signs) * widths
        settings.inertia_scale, settings.inertia_products = scale0 + corner[:3], products0 + corner[3:]
        try:
            settings.true_inertia(inertia_model_B)
        except ValueError as exc:
            raise PhysicalConfigError(
                f"{src}: physical.inertia_scale_dispersion, inertia_products_dispersion: at inertia_scale "
                f"{(scale0 + corner[:3]).tolist()} and inertia_products {(products0 + corner[3:]).tolist()} kg m^2 (a "
                f"corner of the dispersions): {exc} (spacecraft.J is the controller's)"
            ) from exc


def physical_truth(cfg: Config, controller_body: Any, truth_shape: Shape) -> PhysicalTruth:
    """The nominal truth's physical environment of ``cfg`` (its ``[physical]`` section): the truth body on
    ``truth_shape`` (m, A, centroid at the origin) whose mass is the ``controller_body``'s (a
    ``PolyhedronGravity``) times simulation.density_scale, and the spacecraft of mass physical.mass and inertia
    spacecraft.J as the controller knows them. PhysicalConfigError naming the field for a core or lobe outside
    the body, a region of non-positive density, or a truth inertia that is no inertia tensor, at the nominal or
    anywhere within the dispersions."""
    p, src = cfg.physical, cfg.source
    inertia_model_B = np.asarray(cfg.spacecraft.J, dtype=float)
    target_mass = float(controller_body.mass) * cfg.simulation.density_scale
    dispersion = _dispersion(cfg)
    regions: list[Region] = []
    for name, scale, density, spread, center in (
        ("core", p.core_scale, p.core_density, dispersion.core_density, np.zeros(3)),
        ("lobe", p.lobe_scale, p.lobe_density, dispersion.lobe_density, np.asarray(p.lobe_center_A, dtype=float)),
    ):
        if density == 0.0 and spread == 0.0:
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
        regions.append(Region(name, part, float(density), center))
    nominal = tuple(r for r in regions if r.density != 0.0)
    base_density, lowest = _base_density(truth_shape, nominal, target_mass)
    if not lowest > 0.0:
        raise PhysicalConfigError(
            f"{src}: physical.core_density, lobe_density: the body's density around the core and the lobe would be "
            f"{base_density:.4g} kg/m^3 and the lightest region's {lowest:.4g} kg/m^3; every region needs a positive density"
        )
    _check_density_range(src, truth_shape, tuple(regions), dispersion, target_mass)
    body = _body(truth_shape, tuple(regions), target_mass)
    settings = physical_settings(cfg)
    try:
        settings.validate()
        inertia_true = np.asarray(settings.true_inertia(inertia_model_B))
    except ValueError as exc:
        name = "inertia_scale" if "inertia_scale" in str(exc) else "inertia_products"
        raise PhysicalConfigError(f"{src}: physical.{name}: {exc} (spacecraft.J is the controller's)") from exc
    _check_inertia_range(src, physical_settings(cfg), inertia_model_B, dispersion)
    au_r = _core.dynamics.ASTRONOMICAL_UNIT / cfg.environment.R
    d = cfg.disturbance
    return PhysicalTruth(
        parts=body.parts,
        center_of_mass_offset_A=body.center_of_mass_offset_A,
        gm=body.gm,
        mass=body.mass,
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
        regions=tuple(regions),
        target_mass=target_mass,
        dispersion=dispersion,
        thrust_error_B=np.eye(3),
        torque_error_B=np.eye(3),
        actuators={
            "model": "nominal",
            "frame": "B",
            **{k: 0.0 for k in ("scale_error_p", "misalignment_p", "scale_error_r", "misalignment_r")},
        },
    )
