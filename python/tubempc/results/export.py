"""Scenario files for C++ programs: the closed loop of :mod:`tubempc.sim.closed_loop` written out so that a
program embedding the C++ core (``examples/cpp/closed_loop``) flies the same mission without Python.

The format (``tubempc-scenario``: versioned plain text, one record per model constant, setting or
array, every double with 17 significant digits) is documented in
``cpp/include/tubempc/io/scenario.hpp``; the C++ core both writes it (``_core.io.write_scenario``, the
one writer) and reads it (:func:`read_scenario`, the one reader).

:func:`export_scenario` writes, into a folder:

- ``scenario.txt``: the controller's and the truth's models (:func:`tubempc.scenario.build_scenario`),
  the closed loop's MPC settings (:func:`tubempc.scenario.mpc_settings`), the reference, the whole
  controller of both methods (identification, tube policy, initial designs and TBMPC-FFA's library:
  :mod:`tubempc.design.library`), x0, x_f and the truth propagator;
- ``shape.obj`` (and ``truth_shape.obj`` if the truth's shape differs): the meshes in metres;
- ``config.toml``: the configuration it came from.

With ``navigation.enabled`` the file carries the navigation system of the run with seed ``seed``
(``navigation.*``: the sensors, the filter, the sigmas, the landmark catalogue of
:func:`tubempc.scenario.navigation.landmark_catalogue`, the system's seed ``seed + NAV_SEED_OFFSET`` and the
error set's chi-square scale); with ``spacecraft.actuators`` other than "ideal", the actuators of that
run (``actuators.*``: the truth's thrusters with the run's scale and misalignment errors and faults, the
wheels, the momentum dump, the modulation and allocation settings) and the certified actuation-error
sets of the controller; with ``abort.enabled``, the safe abort (``abort.*``: the supervision's settings with the
library's commit step, the hover reference, the abort controller's designs and a commanded abort's step). Faults
(``[faults]``) are not part of the file. The simulated additive disturbance and the ideal actuators' mismatch
(``[disturbance]``) are not part of the file (the C++ example flies the undisturbed mission, or the
disturbance given with ``--disturbance``). A C++ program has no background LMI designs: it flies what
``tube.design_worker = "none"`` flies in Python (the library stands in at a due design).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from ..config import Config
from ..design.abort import abort_library, abort_settings, command_step
from ..design.library import controller_designs, controller_settings
from ..models.dynamics import ProximityModel
from ..scenario.build import Scenario, ScenarioError, build_scenario, mpc_settings, propagator_settings
from ..scenario.navigation import NAV_SEED_OFFSET, error_set_scale, landmark_catalogue, navigation_settings
from ..scenario.shapes import Shape, save_shape

__all__ = ["FORMAT_VERSION", "export_scenario", "read_scenario"]

FORMAT_VERSION: int = _core.io.FORMAT_VERSION
read_scenario = _core.io.read_scenario


def _same_mesh(a: Shape, b: Shape) -> bool:
    return bool(np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces))


def _body(model: ProximityModel, shape_file: str) -> Any:
    body = _core.io.BodyModel()
    body.params = model.params
    body.density = float(model.gravity.density)
    body.shape = shape_file
    body.shape_unit_scale = 1.0  # shapes are written in metres
    return body


def _navigation(scn: Scenario, seed: int) -> Any:
    """The ``navigation.*`` records: what :func:`tubempc.scenario.navigation.new_navigation` builds for ``seed``
    in the project's plant (its drawn disturbance a jump at the period's end, as the C++ example flies it)."""
    n = _core.io.NavigationScenario()
    cfg = scn.config
    n.enabled = cfg.navigation.enabled
    if n.enabled:
        n.settings = navigation_settings(cfg)
        n.landmarks = landmark_catalogue(scn)
        n.seed = int(seed) + NAV_SEED_OFFSET
        n.error_set_scale = error_set_scale(cfg.navigation.error_set_probability)
    return n


def _actuators(scn: Scenario, seed: int) -> Any:
    """The ``actuators.*`` records: the actuation system a run with ``seed`` flies
    (:meth:`tubempc.scenario.actuators.ScenarioActuation.system`, as :func:`tubempc.sim.closed_loop.simulate` builds it)."""
    a = _core.io.ActuatorScenario()
    a.enabled = scn.actuation is not None
    if scn.actuation is not None:
        system = scn.actuation.system(int(seed) + 1)
        cluster, wheels = system.cluster, system.wheels
        a.thrusters = [cluster.thruster(i) for i in range(len(cluster))]
        a.wheels = [wheels.wheel(j) for j in range(len(wheels))]
        a.momentum_dump = wheels.dump_settings
        a.wheel_momentum = np.asarray(wheels.momentum, dtype=float)
        a.settings = system.settings
    return a


def _abort(scn: Scenario) -> Any:
    """The ``abort.*`` records: the safe abort a run with ``[abort]`` flies (:mod:`tubempc.design.abort`: the
    supervision's settings with the library's commit step, the hover, the abort controller's designs, a commanded
    abort's step)."""
    a = _core.io.AbortScenario()
    a.enabled = scn.config.abort.enabled
    if a.enabled:
        library = abort_library(scn)
        a.settings = abort_settings(scn, library)
        a.hover = library.hover.core()
        a.designs = library.designs
        a.command_step = command_step(scn)
    return a


def export_scenario(
    cfg: Config, out_dir: str | Path, *, cache_dir: str | Path | None = None, seed: int | None = None
) -> Path:
    """Writes ``scenario.txt``, ``shape.obj`` (+ ``truth_shape.obj``) and ``config.toml`` for ``cfg``
    into ``out_dir`` (created if needed) and returns the path of ``scenario.txt``.

    ``cache_dir``: reference-trajectory cache (:func:`tubempc.scenario.build_scenario`); ``seed``: the run
    whose navigation system (its sensors' noise) and actuators (the truth's thruster errors, random
    faults) the file carries, as :func:`tubempc.sim.closed_loop.simulate` with that seed builds them (default:
    ``disturbance.seed``, as ``tubempc run``).
    """
    from .. import __version__

    if cfg.disturbance.model == "physical":
        raise ScenarioError(
            f'{cfg.source}: disturbance.model: "physical" is not part of the scenario file (format version 5 holds a '
            'homogeneous truth body and no environment); export the scenario with disturbance.model = "drawn"'
        )
    seed = cfg.disturbance.seed if seed is None else int(seed)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    scn = build_scenario(cfg, cache_dir=cache_dir)
    shape: Shape = scn.model.gravity.shape
    truth_shape: Shape = scn.truth.gravity.shape
    save_shape(out / "shape.obj", shape, unit="m")
    truth_file = "shape.obj"
    if not _same_mesh(shape, truth_shape):
        truth_file = "truth_shape.obj"
        save_shape(out / truth_file, truth_shape, unit="m")
    cfg.save(out / "config.toml")

    s = _core.io.ScenarioFile()
    s.model, s.truth = _body(scn.model, "shape.obj"), _body(scn.truth, truth_file)
    s.propagator = propagator_settings(cfg)
    s.settings = mpc_settings(scn)
    s.reference = scn.reference.core()
    s.has_controller = True
    s.controller = controller_settings(scn, "ffa")
    s.tbmpc_designs, s.ffa_designs = controller_designs(scn, "tbmpc"), controller_designs(scn, "ffa")
    s.x0, s.xf = scn.x0, scn.xf
    s.navigation, s.actuators, s.abort = _navigation(scn, seed), _actuators(scn, seed), _abort(scn)
    path = out / "scenario.txt"
    comment = (
        f"exported by tubempc {__version__} from {cfg.source} (config sha256 {cfg.hash()}), run seed {seed}\n"
        f"shape: {scn.shape_source}; mission: T = {scn.n_steps} steps of {cfg.mpc.dt} s; "
        "controller: TBMPC's and TBMPC-FFA's LMI designs of k = 0 and TBMPC-FFA's library"
    )
    _core.io.write_scenario(str(path), s, comment)
    return path
