"""What a closed-loop run takes from its scenario, built once per scenario (:func:`loop_setup`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..config import DisturbanceSection, TubeSection
from ..design.library import tube_designers
from ..design.tube import TubeDesigner
from ..models.disturbances import ActuatorMismatch, AdditiveDisturbance
from ..models.dynamics import ProximityModel, params_to_config
from ..scenario.actuators import ScenarioActuation
from ..scenario.build import Scenario, mpc_settings, propagator_settings
from ..scenario.physical import PhysicalTruth

__all__ = ["LoopSetup", "loop_setup", "run_truth"]


@dataclass(frozen=True)
class LoopSetup:
    """What a closed-loop run (:func:`tubempc.sim.closed_loop.simulate`) takes from the configuration,
    built once per scenario (:func:`loop_setup`): the MPC's settings, the LMI tube
    designers' arguments, the truth propagator's options, the tube policy's section, and the plant's
    disturbance and actuator errors, drawn per run from its seed."""

    mpc_settings: Any  # _core.mpc.Settings (the controller copies it)
    designer_specs: tuple[dict[str, Any], dict[str, Any]]  # TubeDesigner arguments: translation, rotation
    propagator: Any  # _core.dynamics.PropagatorSettings of the truth
    disturbance: DisturbanceSection
    tube: TubeSection
    n_steps: int
    actuation: ScenarioActuation | None = None

    def designers(self) -> tuple[TubeDesigner, TubeDesigner]:
        """A run's own tube designers (a designer keeps its last design, so runs do not share them)."""
        return TubeDesigner(**self.designer_specs[0]), TubeDesigner(**self.designer_specs[1])

    def plant_disturbance(self, seed: int) -> AdditiveDisturbance:
        """The simulated additive disturbance of a run with seed ``seed`` (``[disturbance]``)."""
        d = self.disturbance
        return AdditiveDisturbance(d.S_p, d.S_r, seed=seed, growth_p=d.growth_p, growth_r=d.growth_r, n_steps=self.n_steps)

    def actuators(self, seed: int) -> ActuatorMismatch:
        """The actuator errors of a run with seed ``seed`` (drawn from ``seed + 1``)."""
        d = self.disturbance
        return ActuatorMismatch(seed + 1, d.scale_error_p, d.misalignment_p, d.scale_error_r, d.misalignment_r)


def loop_setup(scn: Scenario) -> LoopSetup:
    """Everything the closed loop takes from the configuration, built once for the scenario (kept in
    ``Scenario.loop_setup``)."""
    if scn.loop_setup is None:
        cfg = scn.config
        designers = tube_designers(cfg, scn.input_bounds)
        scn.loop_setup = LoopSetup(
            mpc_settings=mpc_settings(scn),
            designer_specs=(designers[0].spec, designers[1].spec),
            propagator=propagator_settings(cfg),
            disturbance=cfg.disturbance,
            tube=cfg.tube,
            n_steps=scn.n_steps,
            actuation=scn.actuation,
        )
    setup: LoopSetup = scn.loop_setup
    return setup


def run_truth(scn: Scenario, seed: int, dispersed: bool) -> tuple[ProximityModel, PhysicalTruth | None]:
    """The truth a run flies: its model (``ProximityModel``: gravity, inertia, ...) and, with disturbance.model =
    "physical", its physical environment. A single run (``dispersed`` false) flies the scenario's nominal truth
    (``Scenario.truth``, ``Scenario.physical``); a campaign's run (``dispersed``) in a physical environment flies
    :meth:`tubempc.scenario.physical.PhysicalTruth.dispersed` of its seed: the body of its drawn density contrasts
    and the truth's drawn inertia. The drawn model has no dispersion of its own here (its disturbance and actuator
    errors are drawn from the seed in every run)."""
    if scn.physical is None or not dispersed:
        return scn.truth, scn.physical
    physical = scn.physical.dispersed(seed)
    params = {**params_to_config(scn.truth.params), "inertia_B": physical.inertia_true_B.tolist()}
    return ProximityModel(physical.gravity(), params), physical
