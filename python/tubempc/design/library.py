"""The LMI designs a controller flies with, computed at set-up (docs/model.md "Tube update"): no
semidefinite program runs inside a control step.

- the initial designs of k = 0 about the reference's first node: TBMPC's for the prior's disturbance
  set P_W0 = pw_scale S^_0 (the tube it keeps for the whole mission), TBMPC-FFA's for
  (1 + redesign_margin) P_W0;
- the library of TBMPC-FFA: designs for the ladder P_W = c P_W0, c = library_ratio^j inside
  ``tube.library_range``, about the same node. At a step the C++ controller
  (``_core.control.Controller``) takes the smallest design whose set covers the identified P_W (a
  generalised-eigenvalue test) and certifies it for the step's linearisation by the Lyapunov update
  (``_core.control.lyapunov_tube``): a fixed cost, known in advance. Designs the LMI cannot give
  (a set too large for the input bound) are left out of the ladder.

Every design kept is certified exactly at its own linearisation (:func:`tubempc.design.tube.certify_design`).
The designs depend on the configuration and the reference only, so a scenario computes them once
(:func:`controller_designs` keeps them in ``Scenario.tube_designs``).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..config import Config
from ..scenario.build import P_INPUTS, P_STATES, R_INPUTS, R_STATES, Scenario
from .tube import DesignResult, TubeDesigner

__all__ = [
    "SharedDesigns",
    "adopt_shared_designs",
    "controller_designs",
    "controller_settings",
    "initial_tube",
    "kept_for_the_mission",
    "library_scales",
    "memory_weight",
    "mission_controller",
    "new_controller",
    "shared_designs",
    "subsystem_design",
    "tube_designers",
]

Array = npt.NDArray[np.float64]


def library_scales(lo: float, hi: float, ratio: float) -> list[float]:
    """The ladder c = ratio^j, j integer, with lo <= c <= hi (ascending)."""
    j0, j1 = math.ceil(math.log(lo) / math.log(ratio) - 1e-9), math.floor(math.log(hi) / math.log(ratio) + 1e-9)
    return [float(ratio**j) for j in range(j0, j1 + 1)]


def subsystem_design(res: DesignResult, P_W: Array) -> Any:
    """A feasible :class:`tubempc.design.tube.DesignResult` designed for ``P_W`` as a ``_core.control.SubsystemDesign``."""
    if not res.feasible or res.K is None or res.Pe is None:
        raise ValueError(f"an infeasible design ({res.status.name}) cannot be flown")
    return _core.control.SubsystemDesign(res.K, res.alpha, P_W, res.Pe)


def actuation_error_shapes(scn: Scenario) -> tuple[Array, Array] | None:
    """The input-error sets of the actuators, {e : e^T E^-1 e <= 1} per subsystem: the actuators' certified
    ones (M38), or with ideal actuators and ``spacecraft.input_gain_error`` = eps > 0 the balls of radius
    eps sqrt(3) u_max and eps sqrt(3) T_max (|e| <= eps |u| for any u in the input box); None: the input is
    exact."""
    if scn.actuation is not None:
        return scn.actuation.error_shapes()
    eps = scn.config.spacecraft.input_gain_error
    if eps <= 0.0:
        return None
    u_max, T_max = scn.input_bounds
    return (3.0 * (eps * u_max) ** 2 * np.eye(3), 3.0 * (eps * T_max) ** 2 * np.eye(3))


def input_error_shapes(scn: Scenario, method: str) -> tuple[Array, Array] | None:
    """The input-error sets ``method``'s tube carries per subsystem (``ControllerSettings.actuation_error``): the
    actuators' certified ones (M38), with TBMPC-FFA's feed-forward box added when it is on (M43, the call the
    controller makes itself); None for ideal actuators without a feed-forward."""
    ident = scn.config.identification
    E = actuation_error_shapes(scn)
    if method != "ffa" or not ident.feedforward:
        return E
    u_max, T_max = scn.input_bounds
    E_p, E_r = E if E is not None else (np.zeros((3, 3)), np.zeros((3, 3)))
    grow = _core.control.input_error_with_feedforward
    rho = ident.feedforward_limit
    return np.asarray(grow(E_p, np.full(3, rho * u_max))), np.asarray(grow(E_r, np.full(3, rho * T_max)))


def _prior_P_W(scn: Scenario, method: str) -> tuple[Array, Array]:
    """The prior's P_W per subsystem; with input-error sets (actuators, feed-forward), grown by B E (M38) about
    the first node."""
    ident = scn.config.identification
    priors = ident.pw_scale * np.asarray(ident.S0_p), ident.pw_scale * np.asarray(ident.S0_r)
    E = input_error_shapes(scn, method)
    if E is None:
        return priors
    grown = (
        np.asarray(_core.actuators.disturbance_with_actuation_error(P, B, E_s))
        for P, (_, B), E_s in zip(priors, _node0(scn), E, strict=True)
    )
    return next(grown), next(grown)


def _node0(scn: Scenario) -> list[tuple[Array, Array]]:
    Ad, Bd, _ = scn.model.discretize(0.0, scn.reference.x[0], scn.reference.u[0], scn.config.mpc.dt)
    return [(Ad[P_STATES, P_STATES], Bd[P_STATES, P_INPUTS]), (Ad[R_STATES, R_STATES], Bd[R_STATES, R_INPUTS])]


def _initial(des: TubeDesigner, A: Array, B: Array, P_W: Array, what: str) -> Any:
    res = des.design(A, B, P_W, None)
    if not res.feasible:
        raise RuntimeError(
            f"initial tube design ({what}) infeasible ({res.status.name}); check identification priors and input limits"
        )
    return subsystem_design(res, P_W)


#: Bisections of the largest feasible scale between the ladder's last feasible and first infeasible rung.
_TOP_BISECTIONS = 4


def _library(des: TubeDesigner, A: Array, B: Array, P_W0: Array, scales: list[float]) -> list[Any]:
    """The ladder's designs, ascending; it ends at the first rung the LMI cannot design (feasibility is
    monotone in the scale) with the largest feasible scale below that rung, found by bisection: the
    gentlest gain the input bound allows, which the largest identified sets need."""
    out = []
    alpha = None
    last = None
    for c in scales:
        res = des.design(A, B, c * P_W0, alpha)
        if not res.feasible:
            if last is not None:
                lo, hi = last, c
                for _ in range(_TOP_BISECTIONS):
                    mid = math.sqrt(lo * hi)
                    top = des.design(A, B, mid * P_W0, alpha)
                    if top.feasible:
                        lo = mid
                        out.append(subsystem_design(top, mid * P_W0))
                    else:
                        hi = mid
                out.sort(key=lambda d: float(np.trace(d.P_W)))
            break
        out.append(subsystem_design(res, c * P_W0))
        alpha, last = res.alpha, c
    return out


def controller_designs(scn: Scenario, method: str) -> Any:
    """The ``_core.control.ControllerDesigns`` of ``method`` ("tbmpc": the prior's design, no library;
    "ffa": the design for (1 + margin) P_W0 and the library), computed once per scenario."""
    key = f"designs:{method}"
    if key not in scn.tube_designs:
        t = scn.config.tube
        designers = tube_designers(scn.config, scn.input_bounds)
        nodes = _node0(scn)
        priors = _prior_P_W(scn, method)
        d = _core.control.ControllerDesigns()
        if method == "tbmpc":
            d.initial_p, d.initial_r = (
                _initial(des, A, B, P, what)
                for des, (A, B), P, what in zip(designers, nodes, priors, ("p", "r"), strict=True)
            )
        else:
            scale = 1.0 + t.redesign_margin
            d.initial_p, d.initial_r = (
                _initial(des, A, B, scale * P, what)
                for des, (A, B), P, what in zip(designers, nodes, priors, ("p", "r"), strict=True)
            )
            scales = library_scales(t.library_range[0], t.library_range[1], t.library_ratio)
            d.library_p, d.library_r = (
                _library(des, A, B, P, scales) for des, (A, B), P in zip(designers, nodes, priors, strict=True)
            )
        scn.tube_designs[key] = d
    return scn.tube_designs[key]


#: A method's set-up designs as plain arrays (picklable: sent to a campaign's workers): per field of
#: ``_core.control.ControllerDesigns`` ("initial_p", "initial_r", "library_p", "library_r") the
#: (K, alpha, P_W, Pe) of each ``_core.control.SubsystemDesign``.
SharedDesigns = dict[str, dict[str, list[tuple[Array, float, Array, Array]]]]

_DESIGN_FIELDS = ("initial_p", "initial_r", "library_p", "library_r")


def shared_designs(scn: Scenario, methods: tuple[str, ...]) -> SharedDesigns:
    """The set-up designs of ``methods`` (:func:`controller_designs`, made here once) as plain arrays, for
    the workers of a campaign to adopt (:func:`adopt_shared_designs`) instead of designing them again:
    a ``SubsystemDesign`` is its four fields, so the copy flies the same bits."""
    out: SharedDesigns = {}
    for m in methods:
        d = controller_designs(scn, m)
        out[m] = {}
        for name in _DESIGN_FIELDS:
            value = getattr(d, name)
            designs = value if isinstance(value, list) else [value]
            out[m][name] = [
                (np.array(x.K), float(x.alpha), np.array(x.P_W), np.array(x.Pe)) for x in designs if x is not None
            ]
    return out


def adopt_shared_designs(scn: Scenario, shared: SharedDesigns) -> None:
    """Gives the scenario the set-up designs another process made (:func:`shared_designs`): the methods'
    :func:`controller_designs` return them without designing."""
    for m, fields in shared.items():
        key = f"designs:{m}"
        if key in scn.tube_designs:
            continue
        d = _core.control.ControllerDesigns()
        for name in _DESIGN_FIELDS:
            designs = [_core.control.SubsystemDesign(K, alpha, P_W, Pe) for K, alpha, P_W, Pe in fields[name]]
            if name.startswith("library"):
                setattr(d, name, designs)
            elif designs:
                setattr(d, name, designs[0])
        scn.tube_designs[key] = d


def _identifier_settings(lam: float, w0: Array, S0: Array, prior_memory: float, eig_floor: float, pw_scale: float) -> Any:
    s = _core.control.IdentifierSettings()
    s.lambda_, s.w0, s.S0 = lam, np.asarray(w0, dtype=float), np.asarray(S0, dtype=float)
    s.prior_weight = prior_memory * memory_weight(lam)
    s.eig_floor, s.pw_scale = eig_floor, pw_scale
    return s


def controller_settings(
    scn: Scenario,
    method: str,
    *,
    lambda_p: float | None = None,
    lambda_r: float | None = None,
    background_designs: bool = False,
) -> Any:
    """The ``_core.control.ControllerSettings`` of ``method`` from the configuration; ``lambda_p`` and
    ``lambda_r`` override the forgetting factors; ``background_designs``: the caller offers LMI designs
    (``Controller.adopt``) when a design is due, instead of the library."""
    cfg = scn.config
    ident, t = cfg.identification, cfg.tube
    s = _core.control.ControllerSettings()
    s.method = _core.control.Method.from_string(method)
    s.measured_input = _core.control.MeasuredInput.from_string(ident.measured_input)
    s.feedforward = ident.feedforward
    s.feedforward_limit = ident.feedforward_limit
    common = (ident.prior_memory, ident.eig_floor, ident.pw_scale)
    s.identification_p = _identifier_settings(lambda_p or ident.lambda_p, ident.w0_p, ident.S0_p, *common)
    s.identification_r = _identifier_settings(lambda_r or ident.lambda_r, ident.w0_r, ident.S0_r, *common)
    tube = _core.control.TubePolicySettings()
    tube.redesign_margin = t.redesign_margin
    tube.alpha_search_period = t.alpha_search_period
    tube.background_designs = background_designs
    s.tube = tube
    E = actuation_error_shapes(scn)
    if E is not None:  # the controller adds the feed-forward's box itself
        s.actuation_error = list(E)
    return s


def new_controller(
    scn: Scenario,
    method: str,
    mpc_settings: Any,
    *,
    lambda_p: float | None = None,
    lambda_r: float | None = None,
    background_designs: bool = False,
) -> Any:
    """A ``_core.control.Controller`` of ``method`` set up for the scenario's mission."""
    ctrl = _core.control.Controller(
        _core.mpc.LinearizedProximityModel(scn.model.core),
        mpc_settings,
        controller_settings(scn, method, lambda_p=lambda_p, lambda_r=lambda_r, background_designs=background_designs),
    )
    ctrl.setup(scn.reference.core(), controller_designs(scn, method))
    return ctrl


@contextlib.contextmanager
def mission_controller(
    scn: Scenario,
    method: str,
    mpc_settings: Any,
    *,
    lambda_p: float | None = None,
    lambda_r: float | None = None,
    background_designs: bool = False,
) -> Iterator[Any]:
    """:func:`new_controller`'s controller for one run, set up once per scenario and process: a controller an
    earlier run of the scenario left with these arguments (``mpc_settings`` the scenario's, the designs its
    :func:`controller_designs`; not with ``lambda_p`` or ``lambda_r``, a sweep's), reset to k = 0
    (``Controller.reset``: the MPC without a plan, the identifiers at their prior, the initial designs), else a
    new one; kept in the scenario for the next run when the run ends. A run on a reset controller flies the bits
    of one on a new controller (tests/py/sim/test_closed_loop.py); runs at once (threads) each get their own."""

    def make() -> Any:
        return new_controller(
            scn, method, mpc_settings, lambda_p=lambda_p, lambda_r=lambda_r, background_designs=background_designs
        )

    # A sweep's forgetting factors (lambda_p, lambda_r) make a controller of their own, not kept: a grid of them
    # would keep one controller (tens of MB) per point.
    if lambda_p is not None or lambda_r is not None:
        yield make()
        return
    with kept_for_the_mission(scn, (method, background_designs, id(mpc_settings)), make) as ctrl:
        yield ctrl


@contextlib.contextmanager
def kept_for_the_mission(scn: Scenario, key: Any, make: Callable[[], Any]) -> Iterator[Any]:
    """An object set up for the scenario's mission (a ``_core.control.Controller`` or ``SafeAbort``: anything with a
    ``reset`` back to k = 0) that an earlier run of the scenario left under ``key``, reset, else ``make()``; kept
    in the scenario (``Scenario.controllers``) for the next run when this one ends."""
    kept = scn.controllers.get(key)
    if kept:
        obj = kept.pop()
        obj.reset()
    else:
        obj = make()
    try:
        yield obj
    finally:
        scn.controllers.setdefault(key, []).append(obj)


def tube_designers(cfg: Config, bounds: tuple[float, float] | None = None) -> tuple[TubeDesigner, TubeDesigner]:
    """LMI tube designers of the translational and rotational subsystems (paper Eq. 25).

    ``tube.weighting = "normalized"``: Q = inverse prior variances, R = input_weight / u_max^2;
    ``"mpc"``: the MPC weights. ``bounds``: (u_max, T_max) (:attr:`Scenario.input_bounds`; default the
    configured ones).
    """
    m, t = cfg.mpc, cfg.tube
    u_max, T_max = bounds or (cfg.spacecraft.u_max, cfg.spacecraft.T_max)
    if t.weighting == "mpc":
        Qp, Rp, Qr, Rr = np.diag(m.Q_p), np.diag(m.R_p), np.diag(m.Q_r), np.diag(m.R_r)
    else:
        ident = cfg.identification
        Qp = np.diag(1.0 / np.diag(ident.S0_p))
        Qr = np.diag(1.0 / np.diag(ident.S0_r))
        Rp = t.input_weight * np.eye(3) / u_max**2
        Rr = t.input_weight * np.eye(3) / T_max**2
    return (
        TubeDesigner(Q=Qp, R=Rp, u_max=u_max, max_solves=t.max_solves),
        TubeDesigner(Q=Qr, R=Rr, u_max=T_max, max_solves=t.max_solves),
    )


def memory_weight(lam: float) -> float:
    """The recursion's steady-state weight zeta(inf) = q / (1 - q), q = e^(lam - 1) (paper Eq. 27): the
    weight of a prior worth one full memory (``identification.prior_memory`` = 1)."""
    q = math.exp(lam - 1.0)
    return q / (1.0 - q)


def initial_tube(scn: Scenario) -> tuple[Array, Array]:
    """TBMPC's tube (K (6, 12), Pe (12, 12)): designed at k = 0 from the identification prior
    P_W = pw_scale S^_0 about the reference's first node (:func:`tubempc.design.library.controller_designs`)."""
    d = controller_designs(scn, "tbmpc")
    K = np.zeros((6, 12))
    Pe = np.zeros((12, 12))
    K[P_INPUTS, P_STATES], K[R_INPUTS, R_STATES] = d.initial_p.K, d.initial_r.K
    Pe[P_STATES, P_STATES], Pe[R_STATES, R_STATES] = d.initial_p.Pe, d.initial_r.Pe
    return K, Pe
