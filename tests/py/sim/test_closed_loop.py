"""A short closed loop of both methods on the default scenario (generated shape)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from tubempc.analysis.metrics import tube_status_certified
from tubempc.analysis.runner import run_summary
from tubempc.config import load_config
from tubempc.design.tube import lmi_residual
from tubempc.results import RunRecord, load_record, save_record
from tubempc.scenario import P_STATES, R_STATES, build_scenario
from tubempc.sim.closed_loop import simulate


@pytest.fixture(scope="module")
def scenario(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return build_scenario(load_config(), cache_dir=tmp_path_factory.mktemp("cache"))


def test_reference_meets_boundary_and_constraints(scenario) -> None:  # type: ignore[no-untyped-def]
    ref = scenario.reference
    cfg = scenario.config
    assert ref.converged and ref.max_defect < 1e-3
    np.testing.assert_allclose(ref.x[0], scenario.x0, atol=1e-6)
    np.testing.assert_allclose(ref.x[-1], scenario.xf, atol=1e-6)
    frac = cfg.simulation.reference_input_fraction
    assert np.linalg.norm(ref.u[:, :3], axis=1).max() <= frac * cfg.spacecraft.u_max * (1 + 1e-6)
    assert np.linalg.norm(ref.u[:, 3:], axis=1).max() <= frac * cfg.spacecraft.T_max * (1 + 1e-6)
    g = np.array([[scenario.model.glide_slope(x)[0], scenario.model.line_of_sight(x)[0]] for x in ref.x])
    assert np.all(g <= 1e-6)


@pytest.mark.parametrize("method", ["tbmpc", "ffa"])
def test_short_closed_loop(scenario, method: str) -> None:  # type: ignore[no-untyped-def]
    res = simulate(scenario, method, seed=3, max_steps=6)
    a = res  # the run record
    assert a.x.shape == (7, 12) and a.u.shape == (6, 6)
    for name in ("x", "u", "v", "z", "Pe_p", "Pe_r", "K", "w", "S_p", "S_r"):
        assert np.all(np.isfinite(getattr(a, name))), name
    assert all(s in ("solved", "solved_inaccurate", "max_iterations") for s in res.statuses), res.statuses
    assert np.all(a.excursion <= 1.0)
    # inputs within the true limits; the state stays near the reference
    cfg = scenario.config
    assert np.all(np.abs(a.u[:, :3]) <= cfg.spacecraft.u_max + 1e-12)
    assert np.all(np.abs(a.u[:, 3:]) <= cfg.spacecraft.T_max + 1e-12)
    assert np.max(np.abs(a.x[:, :3] - a.zbar[:7, :3])) < 1.0
    # TBMPC keeps the tube of step 0; TBMPC-FFA re-designs it from the identified covariance
    changed = not np.allclose(a.Pe_p[0], a.Pe_p[-1])
    assert changed == (method == "ffa")
    assert len(res.tube_statuses) == 6
    if method == "tbmpc":
        assert set(res.tube_statuses) == {"fixed/fixed"}
    else:
        assert res.tube_statuses[0] == "initial/initial" and all(map(tube_status_certified, res.tube_statuses))
    # the identification saw the measured inputs: its covariance left the prior
    assert not np.allclose(a.S_p[-1], np.diag(cfg.identification.S0_p.diagonal()))


def test_ffa_flies_certified_tubes_with_and_without_background_designs(scenario) -> None:  # type: ignore[no-untyped-def]
    """Every step's tube is certified for its step's linearisation and identified set, whether a due design
    comes from the background LMI designs or from the library ("none"); with deterministic adoption the
    background worker does not change the numbers."""
    cfg = scenario.config
    runs = {w: simulate(scenario, "ffa", seed=3, max_steps=24, design_worker=w) for w in ("inline", "thread", "none")}
    np.testing.assert_array_equal(runs["inline"].x, runs["thread"].x)
    for w, rec in runs.items():
        assert all(map(tube_status_certified, rec.tube_statuses)), (w, rec.tube_statuses)
        assert np.all(rec.excursion <= 1.0)
        m = 1.0 + cfg.tube.redesign_margin
        for k in range(1, 24):
            for Pe, S, sx in ((rec.Pe_p, rec.S_p, P_STATES), (rec.Pe_r, rec.S_r, R_STATES)):
                Ad, Bd, _ = scenario.model.discretize(k * cfg.mpc.dt, rec.zbar[k], rec.ubar[k], cfg.mpc.dt)
                su = slice(0, 3) if sx == P_STATES else slice(3, 6)
                K = rec.K[k][su, sx]
                P_W = cfg.identification.pw_scale * S[k - 1]  # the estimate after w_{k-1}, which step k used
                no_margin = "no_margin" in rec.tube_statuses[k].split("/")[0 if sx == P_STATES else 1]
                assert (
                    lmi_residual(
                        Ad[sx, sx],
                        Bd[sx, su],
                        K,
                        Pe[k],
                        P_W * (1.0 if no_margin else m),
                        rec.alpha[k][0 if sx == P_STATES else 1],
                    )
                    <= 0.0
                )
    assert any("library" in s for s in runs["none"].tube_statuses[1:])  # the search steps take library designs
    assert not any("library" in s for s in runs["inline"].tube_statuses)


def test_summary_and_results_file(scenario, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    res = simulate(scenario, "ffa", seed=4, max_steps=3)
    s = run_summary(scenario, res).to_json()
    assert set(s) >= {
        "J_p",
        "J_r",
        "terminal_error",
        "rms_error",
        "max_tube_excursion",
        "constraint_violations",
        "step_time",
        "statuses",
    }
    path = save_record(tmp_path / "ffa.h5", res, config=scenario.config.to_dict(), metadata=s)
    back, info = load_record(path)
    for f in RunRecord.array_fields():  # every declared array comes back with its declared rank
        np.testing.assert_array_equal(getattr(back, f.name), getattr(res, f.name))
        assert getattr(back, f.name).ndim == len(f.metadata["shape"]), f.name
    assert back.statuses == res.statuses and back.tube_statuses == res.tube_statuses and back.seed == 4
    assert info["config"]["mpc"]["horizon"] == 30 and info["metadata"]["J_p"] == s["J_p"]


def test_same_seed_same_run(scenario) -> None:  # type: ignore[no-untyped-def]
    a = simulate(scenario, "ffa", seed=11, max_steps=3)
    b = simulate(scenario, "ffa", seed=11, max_steps=3)
    c = simulate(scenario, "ffa", seed=12, max_steps=3)
    np.testing.assert_array_equal(a.x, b.x)
    assert not np.array_equal(a.x, c.x)


def test_model_mismatch_changes_the_truth_only(tmp_path: Path) -> None:
    """Density, SRP and actuator errors act on the truth; the controller's model and reference stay."""
    base = load_config()
    mis = base.with_overrides(
        {
            "simulation.density_scale": 1.1,
            "simulation.srp_scale": 2.0,
            "disturbance.scale_error_p": 0.05,
            "disturbance.misalignment_r": "1 deg",
        }
    )
    s0 = build_scenario(base, cache_dir=tmp_path)
    s1 = build_scenario(mis, cache_dir=tmp_path)
    np.testing.assert_array_equal(s0.reference.x, s1.reference.x)
    assert s1.truth.gravity.density == pytest.approx(1.1 * s1.model.gravity.density)
    a0 = simulate(s0, "ffa", seed=2, max_steps=4)
    a1 = simulate(s1, "ffa", seed=2, max_steps=4)
    assert np.all(np.isfinite(a1.x)) and not np.allclose(a0.x[1:], a1.x[1:])
    # the identified input sees the mismatch: the residual grows
    assert np.linalg.norm(a1.w[:, :6] - a1.w_true[:, :6]) > np.linalg.norm(a0.w[:, :6] - a0.w_true[:, :6])


def test_figures_render_from_a_short_run(scenario, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from tubempc.analysis import figures

    runs = {m: simulate(scenario, m, seed=1, max_steps=3) for m in ("tbmpc", "ffa")}
    cfg = scenario.config
    made = [
        figures.save(figures.trajectory_3d(runs, cfg.constraints.glide_slope_angle, every=1), tmp_path / "a.png"),
        figures.save(figures.controls(runs, cfg.spacecraft.u_max, cfg.spacecraft.T_max), tmp_path / "d.png"),
        figures.save(figures.tube_projections(runs), tmp_path / "f.png"),
        figures.save(figures.constraints(runs), tmp_path / "g.png"),
    ]
    # the paper's figure pairs: translation (Figs. 4, 6, 9) and rotation (Figs. 5, 7, 10)
    for groups in (figures.TRANSLATION, figures.ROTATION):
        made += [
            figures.save(figures.states(runs, groups), tmp_path / f"states{groups}.png"),
            figures.save(figures.errors(runs, groups), tmp_path / f"errors{groups}.png"),
            figures.save(figures.disturbances(runs, groups=groups), tmp_path / f"w{groups}.png"),
        ]
    # Fig. 11: a disturbance beyond TBMPC's prior bound is counted and marked
    rec = runs["tbmpc"]
    prior = np.r_[np.diag(cfg.identification.S0_p), np.diag(cfg.identification.S0_r)]
    rec.w[1, 7] = 4.0 * np.sqrt(prior[7])  # phi_y, beyond 3 sigma
    fig = figures.exceedances(rec, prior, 9.0)
    assert [ax.get_title() for ax in fig.axes[:3]][1].startswith("1 of 3 steps outside")
    made.append(figures.save(fig, tmp_path / "fig11.png"))
    for p in made:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000


def test_reused_linearizations_fly_the_literal_algorithms_loop(scenario) -> None:  # type: ignore[no-untyped-def]
    """mpc.linearization = "reuse" keeps model data within eps of the plan: far fewer model calls, and
    the same inputs as re-linearising every node at every SCP iteration (Algorithm 1 literally) to
    within what the SCP threshold allows."""
    converged = dataclasses.replace(scenario, config=scenario.config.with_overrides({"mpc.scp_mode": "converge"}))
    literal = dataclasses.replace(
        scenario,
        config=scenario.config.with_overrides({"mpc.linearization": "every_iteration", "mpc.scp_mode": "converge"}),
    )
    a = simulate(converged, "tbmpc", seed=3, max_steps=8)
    b = simulate(literal, "tbmpc", seed=3, max_steps=8)
    N = scenario.config.mpc.horizon
    np.testing.assert_array_equal(b.model_evaluations, N * b.scp_iterations)
    assert a.model_evaluations[0] < N <= b.model_evaluations[0]  # setup linearised about the reference
    assert a.model_evaluations.sum() < 0.5 * b.model_evaluations.sum()
    np.testing.assert_allclose(a.u, b.u, rtol=0, atol=2e-4 * scenario.config.spacecraft.u_max)
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-6)


def test_real_time_iteration_flies_the_converged_loop(scenario) -> None:  # type: ignore[no-untyped-def]
    """mpc.scp_mode = "real_time" (default) solves one QP per step and flies the states of SCP iterated
    to convergence (Algorithm 1, "converge") to within what the SCP threshold allows."""
    converged = dataclasses.replace(scenario, config=scenario.config.with_overrides({"mpc.scp_mode": "converge"}))
    a = simulate(scenario, "ffa", seed=3, max_steps=12)
    b = simulate(converged, "ffa", seed=3, max_steps=12)
    np.testing.assert_array_equal(a.scp_iterations, 1)
    assert b.scp_iterations.max() > 1  # the comparison is not between two single-QP loops
    # one SCP iteration fewer moves the torques by up to ~5e-4 of their bound, the states by ~1e-6
    u_max = np.r_[[scenario.config.spacecraft.u_max] * 3, [scenario.config.spacecraft.T_max] * 3]
    np.testing.assert_array_less(np.abs(a.u - b.u).max(axis=0), 1e-3 * u_max)
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-5)


def test_active_set_qp_solver_flies_the_interior_points_loop(scenario) -> None:  # type: ignore[no-untyped-def]
    """mpc.qp_solver = "active_set" (default) solves most QPs by the warm-started active set; the loop
    flies the same states as PIQP alone ("piqp") to the solvers' tolerances."""
    piqp = dataclasses.replace(scenario, config=scenario.config.with_overrides({"mpc.qp_solver": "piqp"}))
    a = simulate(scenario, "tbmpc", seed=3, max_steps=8)
    b = simulate(piqp, "tbmpc", seed=3, max_steps=8)
    assert a.active_set_solves.sum() >= 0.8 * a.scp_iterations.sum()
    assert b.active_set_solves.sum() == 0 and b.qp_iterations.min() > 0
    np.testing.assert_allclose(a.u, b.u, rtol=0, atol=1e-5 * scenario.config.spacecraft.u_max)
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-6)


def test_held_truth_gravity_flies_the_exact_fields_run_with_fewer_evaluations(tmp_path: Path) -> None:
    """simulation.gravity_expansion_tolerance (docs/model.md M42): the run's truth holds its gravity's expansion
    from period to period; the run stays within the expansion's error of the exact field's run, evaluates the
    field fewer times than the integrator's 8 stages per period, and reports what it found."""
    base = load_config()
    tol = base.simulation.gravity_expansion_tolerance
    assert tol > 0.0
    exact = base.with_overrides({"simulation.gravity_expansion_tolerance": 0.0})
    steps = 30
    held_rec = simulate(build_scenario(base, cache_dir=tmp_path), "tbmpc", seed=4, max_steps=steps)
    exact_rec = simulate(build_scenario(exact, cache_dir=tmp_path), "tbmpc", seed=4, max_steps=steps)
    hold = held_rec.applied["plant"]["gravity_hold"]
    assert hold["tolerance"] == tol
    assert 0 < hold["evaluations"] < 8 * steps / 2
    # found where the expansion was given up, up to a stage's step past the hold: a few times tol (a wrong
    # expansion, e.g. its gradient's sign, would be G d ~ 1e-7 s^-2 x 0.05 m, hundreds of times more)
    assert 0.0 < hold["largest_error"] < 10.0 * tol
    assert "gravity_hold" not in exact_rec.applied["plant"]
    # an acceleration error below 2 tol moves the truth by at most tol t^2 over the run (t = 60 s)
    t = steps * base.mpc.dt
    assert 0.0 < np.abs(held_rec.x[:, :3] - exact_rec.x[:, :3]).max() < tol * t * t


def test_a_reset_controller_flies_the_bits_of_a_new_one(tmp_path: Path) -> None:
    """simulate keeps its controller in the scenario between runs (set up once, Controller.reset per run): a run
    after other runs of the scenario, with background designs adopted into the controller and a navigation
    error set, equals the same run on a fresh scenario to the bit."""
    cfg = load_config(scenario="bennu-tag-nav")
    fresh = simulate(build_scenario(cfg, cache_dir=tmp_path), "ffa", seed=5, max_steps=20, design_worker="inline")
    scn = build_scenario(cfg, cache_dir=tmp_path)
    before = simulate(scn, "ffa", seed=4, max_steps=20, design_worker="inline")
    assert not np.array_equal(before.K[-1], before.K[0])  # a background design was adopted into the controller
    simulate(scn, "ffa", seed=6, max_steps=10, design_worker="inline")
    simulate(scn, "ffa", seed=6, max_steps=2, design_worker="inline", lambda_p=0.97)  # a sweep's: not kept
    assert len(scn.controllers) == 1 and len(next(iter(scn.controllers.values()))) == 1  # one kept, reused
    again = simulate(scn, "ffa", seed=5, max_steps=20, design_worker="inline")
    for name in ("x", "u", "z", "K", "Pe_p", "Pe_r", "w_hat", "alpha"):
        np.testing.assert_array_equal(getattr(again, name), getattr(fresh, name), err_msg=name)
    assert again.navigation is not None and fresh.navigation is not None
    np.testing.assert_array_equal(again.navigation.x_hat, fresh.navigation.x_hat)
