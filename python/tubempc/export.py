"""Scenario files for C++ programs: the closed loop of :mod:`tubempc.closed_loop` written out so that a
program embedding the C++ core (``examples/cpp/closed_loop``) flies the same mission without Python.

The format (``tubempc-scenario 1``: versioned plain text, one record per model constant, setting or
array, every double with 17 significant digits) is documented in
``cpp/include/tubempc/io/scenario.hpp`` and the README; :func:`read_scenario` is the C++ reader.

:func:`export_scenario` writes, into a folder:

- ``scenario.txt``: the controller's and the truth's model constants exactly as
  :func:`tubempc.closed_loop.build_scenario` builds them, the MPC settings of the closed loop
  (``_mpc_settings``: N, dt, Q, R, u_max, SCP threshold, input cost, declared model structures and the
  core's defaults for the rest), the reference (zbar, u_ref, t0 = 0), TBMPC's tube (designed once at
  k = 0 from the identification prior, as :func:`tubempc.closed_loop.simulate` does), x0, x_f and the
  truth propagator (``simulation.integrator``, ``substeps``, ``rtol``);
- ``shape.obj`` (and ``truth_shape.obj`` if the truth's shape differs): the meshes in metres;
- ``config.toml``: the configuration it came from.

The simulated disturbance and actuator mismatch are not part of the file (the C++ example flies
the undisturbed mission).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import numpy.typing as npt

from . import _core
from .closed_loop import Scenario, _block_tube, _mpc_settings, _tube_designers, build_scenario
from .config import Config
from .identification import ForgettingFactorIdentifier
from .shapes import Shape, save_shape

__all__ = ["FORMAT_VERSION", "export_scenario", "initial_tube", "read_scenario", "write_scenario"]

FORMAT_VERSION: int = _core.io.FORMAT_VERSION
read_scenario = _core.io.read_scenario

_Arr = npt.NDArray[np.float64]
_KINEMATICS = {"Paper": "paper", "Exact": "exact"}
_INTEGRATORS = {"RK4": "rk4", "DOPRI5": "dopri5"}
_INPUT_COSTS = {"Paper": "paper", "FromReference": "from_reference"}
_INITIAL_CONDITIONS = {"WhitenedBox": "whitened_box", "Exact": "exact"}
_KKT_SOLVERS = {"SparseLdlt": "sparse_ldlt", "SparseMultistage": "sparse_multistage"}
_BACKENDS = {"PiqpSparse": "piqp", "ActiveSetPiqp": "active_set_piqp"}


def initial_tube(scn: Scenario) -> tuple[_Arr, _Arr]:
    """TBMPC's tube (K (6, 12), Pe (12, 12)): designed at k = 0 from the identification prior
    P_W = pw_scale S^_0 about the reference's first node, as :func:`tubempc.closed_loop.simulate` does."""
    cfg = scn.config
    ident = cfg.identification
    des_p, des_r = _tube_designers(cfg)
    Ad, Bd, _ = scn.model.discretize(0.0, scn.reference.x[0], scn.reference.u[0], cfg.mpc.dt)
    results = []
    for des, lam, w0, S0, sl, su in ((des_p, ident.lambda_p, ident.w0_p, ident.S0_p, slice(0, 6), slice(0, 3)),
                                     (des_r, ident.lambda_r, ident.w0_r, ident.S0_r, slice(6, 12), slice(3, 6))):
        prior = ForgettingFactorIdentifier(lam, w0, S0, prior_weight=ident.prior_weight, eig_floor=ident.eig_floor,
                                           pw_scale=ident.pw_scale)
        res = des.design(Ad[sl, sl], Bd[sl, su], prior.P_W, None)
        if not res.feasible:
            raise RuntimeError(f"initial tube design infeasible ({res.status.name}); "
                               "check identification priors and input limits")
        results.append(res)
    return _block_tube(results[0], results[1])


class _Writer:
    """Records of the scenario format (the same text as the C++ writer, tubempc::io::write_scenario)."""

    def __init__(self, out: TextIO) -> None:
        self.out = out

    def matrix(self, name: str, value: npt.ArrayLike) -> None:
        m = np.asarray(value, dtype=np.float64)
        if m.ndim == 1:
            m = m[:, None]
        if m.ndim != 2:
            raise ValueError(f"{name}: expected a matrix, got shape {m.shape}")
        if m.size == 0:
            m = m.reshape(0, 0)
        if np.isnan(m).any():
            raise ValueError(f"{name}: NaN value")
        self.out.write(f"{name} {m.shape[0]} {m.shape[1]}\n")
        self.out.writelines(" ".join("%.17g" % v for v in row) + "\n" for row in m)  # noqa: UP031

    def scalar(self, name: str, value: float) -> None:
        self.matrix(name, [[float(value)]])

    def text(self, name: str, value: str) -> None:
        if not value.strip() or "\n" in value or value != value.strip() or value.startswith("#"):
            raise ValueError(f"{name}: a text value must be one non-empty line without leading '#' or "
                             f"surrounding blanks, got {value!r}")
        self.out.write(f"{name} text\n{value}\n")


def _body(w: _Writer, prefix: str, params: Mapping[str, Any], density: float, shape: str) -> None:
    w.scalar(prefix + "mu_sun", params["mu_sun"])
    w.scalar(prefix + "orbit_radius", params["orbit_radius"])
    w.scalar(prefix + "beta_srp", params["beta_srp"])
    w.scalar(prefix + "srp_enabled", 1.0 if params["srp_enabled"] else 0.0)
    w.matrix(prefix + "inertia_B", params["inertia_B"])
    w.scalar(prefix + "spin_rate", params["spin_rate"])
    w.scalar(prefix + "spin_angle0", params["spin_angle0"])
    w.text(prefix + "kinematics", params["kinematics"])
    w.scalar(prefix + "glide_slope_angle", params["glide_slope_angle"])
    w.scalar(prefix + "los_angle", params["los_angle"])
    w.matrix(prefix + "boresight_B", params["boresight_B"])
    w.scalar(prefix + "density", density)
    w.text(prefix + "shape", shape)
    w.scalar(prefix + "shape_unit_scale", 1.0)  # shapes are written in metres


def write_scenario(path: str | Path, *, controller: tuple[Mapping[str, Any], float, str],
                   truth: tuple[Mapping[str, Any], float, str], propagator: Any, settings: Any,
                   reference_z: npt.ArrayLike, reference_u: npt.ArrayLike, t0: float, K: npt.ArrayLike,
                   Pe: npt.ArrayLike, x0: npt.ArrayLike, xf: npt.ArrayLike, comment: Sequence[str] = ()) -> Path:
    """Writes a scenario file (format :data:`FORMAT_VERSION`) with every record.

    ``controller`` and ``truth`` are (model parameters as :func:`tubempc.dynamics.params_to_config`
    returns them, density in kg/m^3, shape file in metres relative to the scenario's folder);
    ``propagator`` a ``_core.dynamics.PropagatorSettings``; ``settings`` a ``_core.mpc.Settings``;
    ``reference_z`` (T+1, 12) and ``reference_u`` (T, 6) one node per row; ``K`` (6, 12), ``Pe``
    (12, 12); ``x0``, ``xf`` (12,). ``comment`` lines are written as ``#`` lines after the version.
    """
    z = np.asarray(reference_z, dtype=np.float64)
    u = np.asarray(reference_u, dtype=np.float64)
    if z.ndim != 2 or z.shape[1] != 12 or z.shape[0] < 2 or u.shape != (z.shape[0] - 1, 6):
        raise ValueError(f"reference: expected z (T+1, 12) and u (T, 6) with T >= 1, got {z.shape} and {u.shape}")
    p = Path(path)
    with p.open("w", encoding="utf-8", newline="\n") as out:
        out.write(f"tubempc-scenario {FORMAT_VERSION}\n")
        out.writelines(f"# {line}\n" for line in comment)
        w = _Writer(out)
        _body(w, "model.", *controller)
        _body(w, "truth.", *truth)
        w.text("propagator.method", _INTEGRATORS[propagator.method.name])
        w.scalar("propagator.substeps", propagator.substeps)
        w.scalar("propagator.rtol", propagator.rtol)
        w.scalar("propagator.atol", propagator.atol)
        w.scalar("propagator.max_steps", propagator.max_steps)
        w.scalar("propagator.initial_step", propagator.initial_step)
        s = settings
        w.scalar("mpc.horizon", s.horizon)
        w.scalar("mpc.dt", s.dt)
        w.matrix("mpc.Q", s.Q)
        w.matrix("mpc.R", s.R)
        w.matrix("mpc.u_max", s.u_max)
        w.text("mpc.input_cost", _INPUT_COSTS[s.input_cost.name])
        w.scalar("mpc.scp_eps", s.scp_eps)
        w.text("mpc.initial_condition", _INITIAL_CONDITIONS[s.initial_condition.name])
        w.scalar("mpc.scp_max_iterations", s.scp_max_iterations)
        w.scalar("mpc.trust_region", s.trust_region)
        w.scalar("mpc.qp_eps_abs", s.qp_eps_abs)
        w.scalar("mpc.qp_eps_rel", s.qp_eps_rel)
        w.scalar("mpc.qp_max_iterations", s.qp_max_iterations)
        w.scalar("mpc.qp_inaccurate_tol", s.qp_inaccurate_tol)
        w.scalar("mpc.time_limit", s.time_limit)
        w.scalar("mpc.soft_state_constraints", 1.0 if s.soft_state_constraints else 0.0)
        w.scalar("mpc.soft_terminal", 1.0 if s.soft_terminal else 0.0)
        w.scalar("mpc.soft_penalty", s.soft_penalty)
        w.scalar("mpc.riccati_tol", s.riccati_tol)
        w.scalar("mpc.riccati_max_iterations", s.riccati_max_iterations)
        w.text("mpc.kkt_solver", _KKT_SOLVERS[s.kkt_solver.name])
        w.text("mpc.backend", _BACKENDS[s.backend.name])
        w.scalar("mpc.active_set_max_iterations", s.active_set_max_iterations)
        w.scalar("mpc.qp_scale_cost", 1.0 if s.qp_scale_cost else 0.0)
        w.scalar("mpc.reuse_linearization", 1.0 if s.reuse_linearization else 0.0)
        w.scalar("mpc.qp_preconditioner_iterations", s.qp_preconditioner_iterations)
        w.scalar("mpc.qp_reg_lower_limit", s.qp_reg_lower_limit)
        w.scalar("mpc.qp_retry_reg_lower_limit", s.qp_retry_reg_lower_limit)
        w.matrix("mpc.A_structure", s.A_structure)
        w.matrix("mpc.B_structure", s.B_structure)
        w.matrix("mpc.G_structure", s.G_structure)
        w.scalar("reference.t0", t0)
        w.matrix("reference.z", z)
        w.matrix("reference.u", u)
        w.matrix("tube.K", K)
        w.matrix("tube.Pe", Pe)
        w.matrix("mission.x0", x0)
        w.matrix("mission.xf", xf)
    return p


def _same_mesh(a: Shape, b: Shape) -> bool:
    return bool(np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces))


def export_scenario(cfg: Config, out_dir: str | Path, *, cache_dir: str | Path | None = None) -> Path:
    """Writes ``scenario.txt``, ``shape.obj`` (+ ``truth_shape.obj``) and ``config.toml`` for ``cfg``
    into ``out_dir`` (created if needed) and returns the path of ``scenario.txt``.

    ``cache_dir``: reference-trajectory cache (:func:`tubempc.closed_loop.build_scenario`).
    """
    from . import __version__

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

    sim = cfg.simulation
    prop = _core.dynamics.PropagatorSettings()  # the propagator's defaults, as ProximityModel.propagate's
    if sim.integrator == "rk4":
        prop.method, prop.substeps = _core.dynamics.Integrator.RK4, sim.substeps
    else:
        prop.method, prop.rtol = _core.dynamics.Integrator.DOPRI5, sim.rtol
    K, Pe = initial_tube(scn)
    return write_scenario(
        out / "scenario.txt",
        controller=(scn.model.config(), float(scn.model.gravity.density), "shape.obj"),
        truth=(scn.truth.config(), float(scn.truth.gravity.density), truth_file),
        propagator=prop, settings=_mpc_settings(cfg, scn),
        reference_z=scn.reference.x, reference_u=scn.reference.u, t0=0.0, K=K, Pe=Pe, x0=scn.x0, xf=scn.xf,
        comment=(f"exported by tubempc {__version__} from {cfg.source} (config sha256 {cfg.hash()})",
                 f"shape: {scn.shape_source}; mission: T = {scn.n_steps} steps of {cfg.mpc.dt} s; "
                 "tube: TBMPC's, designed at k = 0 from the identification prior"))
