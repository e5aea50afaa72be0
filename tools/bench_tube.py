"""Time the per-step tube update of both subsystems, warm-started (tube.py, identification.py).

Closed-loop-like data for the packaged scenario: the disturbance covariance comes from the
forgetting-factor identifier fed with the scenario's simulated disturbance, and the
translational model is the double integrator with a slowly rotating gravity-gradient term
(PAPER_NOTES "Linearisation and discretisation"). Usage:

    PYTHONPATH=python python tools/bench_tube.py [--steps 100] [--max-solves 25]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np
from scipy.linalg import expm  # type: ignore[import-untyped]

from tubempc.config import load_config
from tubempc.disturbances import AdditiveDisturbance
from tubempc.identification import ForgettingFactorIdentifier
from tubempc.tube import TubeDesigner


def _discretise(
    Ac: np.ndarray, Bc: np.ndarray, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    n, m = Bc.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = Ac, Bc
    E = expm(M * dt)
    return E[:n, :n], E[:n, n:]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--max-solves", type=int, default=25)
    args = parser.parse_args()
    cfg = load_config()
    dt, idc = cfg.mpc.dt, cfg.identification
    spin = 2.0 * math.pi / cfg.asteroid.spin_period
    gg = 4e-8  # s^-2, order of G M / r^3 at a few hundred metres from Bennu
    Z3, I3 = np.zeros((3, 3)), np.eye(3)
    J_inv = np.linalg.inv(cfg.spacecraft.J)
    A_r, B_r = _discretise(np.block([[Z3, I3], [Z3, Z3]]), np.vstack([Z3, J_inv]), dt)
    tube_p = TubeDesigner(
        Q=np.diag(cfg.mpc.Q_p),
        R=np.diag(cfg.mpc.R_p),
        u_max=cfg.spacecraft.u_max,
        max_solves=args.max_solves,
    )
    tube_r = TubeDesigner(
        Q=np.diag(cfg.mpc.Q_r),
        R=np.diag(cfg.mpc.R_r),
        u_max=cfg.spacecraft.T_max,
        max_solves=args.max_solves,
    )
    id_p = ForgettingFactorIdentifier(
        idc.lambda_p, idc.w0_p, idc.S0_p, prior_weight=idc.prior_weight
    )
    id_r = ForgettingFactorIdentifier(
        idc.lambda_r, idc.w0_r, idc.S0_r, prior_weight=idc.prior_weight
    )
    dist = AdditiveDisturbance(
        cfg.disturbance.S_p, cfg.disturbance.S_r, cfg.disturbance.seed
    )
    alpha_p: float | None = None
    alpha_r: float | None = None
    times: list[float] = []
    solves: list[tuple[int, int]] = []
    for k in range(args.steps + 1):
        c, s = math.cos(spin * k * dt), math.sin(spin * k * dt)
        C = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        G = gg * C @ np.diag([2.0, -1.0, -1.0]) @ C.T
        A_p, B_p = _discretise(np.block([[Z3, I3], [G, Z3]]), np.vstack([Z3, I3]), dt)
        t0 = time.perf_counter()
        rp = tube_p.design(A_p, B_p, id_p.P_W, alpha_prev=alpha_p)
        rr = tube_r.design(A_r, B_r, id_r.P_W, alpha_prev=alpha_r)
        elapsed = time.perf_counter() - t0
        assert rp.feasible and rr.feasible, (rp.status, rr.status)
        alpha_p, alpha_r = rp.alpha, rr.alpha
        if k > 0:  # step 0 is the cold start
            times.append(elapsed)
            solves.append((rp.n_solves, rr.n_solves))
        w_p, w_r = dist.sample()
        id_p.update(w_p)
        id_r.update(w_r)
    ms = sorted(1e3 * t for t in times)
    print(f"steps={len(ms)} warm-started tube update, both subsystems (ms):")
    print(
        f"  mean {statistics.mean(ms):.1f}  median {statistics.median(ms):.1f}  "
        f"p90 {ms[int(0.9 * len(ms))]:.1f}  max {ms[-1]:.1f}"
    )
    sp = [a for a, _ in solves]
    sr = [b for _, b in solves]
    print(
        f"  solves/step: translational mean {statistics.mean(sp):.2f} max {max(sp)}, "
        f"rotational mean {statistics.mean(sr):.2f} max {max(sr)}"
    )
    print(f"  final alpha_p {alpha_p:.4f}  alpha_r {alpha_r:.4f}")


if __name__ == "__main__":
    main()
