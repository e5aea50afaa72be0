"""Own missions without traps (issue #28): shape units and sizes checked, a target inside the body
refused, results folders that re-open anywhere, one meaning per exit status, no artefact reported as a
result, a neutral disturbance for own missions."""

from __future__ import annotations

import dataclasses
import json
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc import _core
from tubempc.config import ConfigError, load_config
from tubempc.models.dynamics import ProximityModel
from tubempc.scenario import (
    PAPER_TARGET_MAX_DEPTH,
    ScenarioError,
    boundary_states,
    build_scenario,
    check_boundary,
    model_params,
    scenario_shape,
)
from tubempc.scenario.bodies import ellipsoid_shape
from tubempc.scenario.shapes import bennu_like_shape, load_shape, save_shape
from tubempc.scenario.sites import inside, ray_cast

RADAR_MODEL = Path(__file__).resolve().parents[4] / "shared" / "data" / "101955bennu.tab"


def _write(tmp_path: Path, text: str, name: str = "mission.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _model(cfg: Any, shape: Any) -> ProximityModel:
    gravity = _core.gravity.PolyhedronGravity(shape.vertices, shape.faces, cfg.asteroid.density)
    return ProximityModel(gravity, model_params(cfg))


# --- 1. shape units -------------------------------------------------------------------------------


def test_a_shape_file_without_its_unit_is_refused(tmp_path: Path) -> None:
    save_shape(tmp_path / "rock.obj", ellipsoid_shape([260.0, 220.0, 180.0], 6, 0.0, 0), unit="m")
    p = _write(tmp_path, '[asteroid]\nshape = "rock.obj"\n')
    with pytest.raises(ConfigError, match=r"mission\.toml: asteroid\.shape_unit: missing.*\"m\" or \"km\""):
        load_config(p)
    # given, it is read; the generated body needs none
    assert load_config(_write(tmp_path, '[asteroid]\nshape = "rock.obj"\nshape_unit = "m"\n')).asteroid.shape_unit == "m"
    assert load_config(_write(tmp_path, "[mpc]\nhorizon = 20\n")).asteroid.shape == "generated"


def test_a_body_read_in_the_wrong_unit_is_refused_with_the_size_in_the_other(tmp_path: Path) -> None:
    bennu = bennu_like_shape(6)
    save_shape(tmp_path / "in_m.obj", bennu, unit="m")
    save_shape(tmp_path / "in_km.obj", bennu, unit="km")
    base = load_config()
    # a metre file read as km: a body of ~246 km
    as_km = base.with_overrides({"asteroid.shape": str(tmp_path / "in_m.obj"), "asteroid.shape_unit": "km"})
    with pytest.raises(ScenarioError, match=r"asteroid\.shape_unit: .*in_m\.obj read in km .* in m it would be 2[0-9.]+ m"):
        scenario_shape(as_km)
    # a km file read in metres: a body of ~0.25 m
    as_m = base.with_overrides({"asteroid.shape": str(tmp_path / "in_km.obj"), "asteroid.shape_unit": "m"})
    with pytest.raises(ScenarioError, match=r"asteroid\.shape_unit: .*in_km\.obj read in m is a body of 0\.2"):
        scenario_shape(as_m)
    # in the right unit both are the same body
    right = [
        scenario_shape(base.with_overrides({"asteroid.shape": str(tmp_path / n), "asteroid.shape_unit": u}))[0]
        for n, u in (("in_m.obj", "m"), ("in_km.obj", "km"))
    ]
    np.testing.assert_allclose(right[0].vertices, right[1].vertices, rtol=1e-12)
    # a small but plausible body far from a hover start (the mission does not fit it)
    save_shape(tmp_path / "pebble.obj", ellipsoid_shape([8.0, 7.0, 6.0], 4, 0.0, 0), unit="m")
    far = base.with_overrides({"asteroid.shape": str(tmp_path / "pebble.obj"), "asteroid.shape_unit": "m"})
    with pytest.raises(ScenarioError, match=r"radii from the start \(boundary\.r0\)"):
        scenario_shape(far)


def test_shape_option_carries_its_own_unit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tubempc.cli import main
    from tubempc.commands import EXIT_USAGE

    save_shape(tmp_path / "km.obj", bennu_like_shape(), unit="km")
    cfg = _write(tmp_path, '[asteroid]\nshape = "generated"\nshape_unit = "m"\n')
    status = main(["run", "--config", str(cfg), "--shape", str(tmp_path / "km.obj"), "--out", str(tmp_path / "o")])
    assert status == EXIT_USAGE and "--shape needs --shape-unit" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    # the unit given with the shape is the shape's, whatever the configuration says
    with pytest.raises(ScenarioError, match="needs its own unit"):
        build_scenario(load_config(cfg), shape_path=tmp_path / "km.obj")
    scn = build_scenario(load_config(cfg), shape_path=tmp_path / "km.obj", shape_unit="km", cache_dir=tmp_path / "c")
    assert 200.0 < scn.shape.mean_radius < 300.0 and scn.config.asteroid.shape_unit == "km"


def test_altitude_target_lies_on_the_surface_along_rf() -> None:
    """Off the axis of an elongated body, the target is terminal_altitude above the surface point on the
    ray of rf (the body at t_f), not above the mesh's farthest extent along rf."""
    cfg = load_config(scenario="itokawa-like").with_overrides(
        {
            "constraints.glide_slope_apex": "centre",
            "constraints.glide_slope_axis": "z",
            "boundary.initial": "given",
            "boundary.terminal": "altitude",
            "boundary.terminal_altitude": "5 m",
            "boundary.rf": [100.0, 60.0, 80.0],
        }
    )
    shape, _ = scenario_shape(cfg)
    model = _model(cfg, shape)
    _, xf = boundary_states(cfg, shape, model)
    r_A = np.asarray(model.C_AL(cfg.mpc.t_f)) @ xf[:3]
    surface = ray_cast(shape, r_A)
    assert np.linalg.norm(r_A) - np.linalg.norm(surface) == pytest.approx(5.0, abs=1e-9)
    np.testing.assert_allclose(np.cross(r_A, surface), 0.0, atol=1e-6)  # on the ray of rf
    assert np.dot(xf[:3], cfg.boundary.rf) > 0.0 and not inside(shape, r_A)[0]


def test_gravity_above_the_input_bound_is_refused(tmp_path: Path) -> None:
    cfg = load_config().with_overrides({"asteroid.density": "2e6 kg/m^3"})  # ~0.13 m/s^2 at the pole
    cfg = cfg.with_overrides({"spacecraft.u_max": "0.1 m/s^2"})
    with pytest.raises(ScenarioError, match=r"spacecraft\.u_max: the body's gravity at the terminal target is"):
        build_scenario(cfg, cache_dir=tmp_path)


# --- 2. a target inside the body --------------------------------------------------------------------


def test_a_paper_target_deeper_than_the_papers_is_refused(tmp_path: Path) -> None:
    base = load_config()
    with pytest.raises(ScenarioError, match=r"boundary\.rf: .* inside the body, 1[0-9.]+ m below the surface"):
        build_scenario(base.with_overrides({"boundary.rf": [0.0, 0.0, 100.0]}), cache_dir=tmp_path)


@pytest.mark.skipif(not RADAR_MODEL.exists(), reason="the Bennu radar model (../shared/data) is not here")
def test_the_papers_own_target_on_the_radar_model_is_flown_with_a_warning() -> None:
    cfg = load_config().with_overrides({"asteroid.shape": str(RADAR_MODEL), "asteroid.shape_unit": "km"})
    shape = load_shape(RADAR_MODEL, unit="km")
    model = _model(cfg, shape)
    x0, xf = boundary_states(cfg, shape, model)
    with pytest.warns(RuntimeWarning, match=r"boundary\.rf: .* inside the body, 6\.7[0-9]* m below the surface"):
        check_boundary(cfg, shape, model, x0, xf)
    assert PAPER_TARGET_MAX_DEPTH - 0.1 < 6.71 < PAPER_TARGET_MAX_DEPTH  # the paper's own depth, just inside
    deeper = cfg.with_overrides({"boundary.rf": [0.0, 0.0, 246.4]})  # 0.1 m deeper than the paper's
    _, xf2 = boundary_states(deeper, shape, model)
    with pytest.raises(ScenarioError, match=r"at most 6\.75 m below"):
        check_boundary(deeper, shape, model, x0, xf2)


def test_every_run_counts_its_states_inside_the_body(tmp_path: Path) -> None:
    from tubempc.analysis.runner import guarantee_lost, run_summary
    from tubempc.sim.closed_loop import simulate

    scn = build_scenario(load_config(), cache_dir=tmp_path)
    rec = simulate(scn, "tbmpc", seed=0, max_steps=4)
    s = run_summary(scn, rec)
    assert s.states_inside_body == 0
    rec.x = rec.x.copy()
    rec.x[2, :3] = 0.0  # the centre of the body
    rec.x[3, :3] = np.asarray(scn.model.C_AL(3 * scn.config.mpc.dt)).T @ np.array([0.0, 0.0, 200.0])
    s = run_summary(scn, rec)
    assert s.states_inside_body == 2
    assert "2 states inside the body" in guarantee_lost(dataclasses.replace(s, steps_outside_tube=0, fallback_steps=0))


# --- 4. one meaning per exit status -------------------------------------------------------------------


def _fake_montecarlo(lost: int, failed: list[int]) -> Any:
    from tubempc.results.summaries import MeanSpread, MonteCarloMethodSummary, MonteCarloSummary

    def fake(*_: Any, **__: Any) -> MonteCarloSummary:
        row = MonteCarloMethodSummary(
            J_p=MeanSpread(mean=1.0, three_sigma=0.0),
            J_r=MeanSpread(mean=1.0, three_sigma=0.0),
            runs_outside_tube=lost,
            max_tube_excursion=2.0 if lost else 0.5,
            runs_with_cone_violation=0,
            terminal_position_error_max_m=0.1,
            runs_inside_body=0,
            runs_guarantee_lost=lost,
        )
        return MonteCarloSummary(
            runs=3,
            executed_now=3,
            failed_runs=failed,
            wall_time_s=1.0,
            methods={"tbmpc": row},
            master_seed=0,
            config_hash="",
        )

    return fake


@pytest.mark.parametrize(("lost", "failed", "status"), [(3, [], 4), (0, [], 0), (3, [1], 5)])
def test_montecarlo_exit_status_means_what_run_s_does(
    lost: int, failed: list[int], status: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import tubempc.analysis.studies
    from tubempc.cli import main

    monkeypatch.setattr(tubempc.analysis.studies, "montecarlo", _fake_montecarlo(lost, failed))
    assert main(["montecarlo", "--runs", "3", "--out", str(tmp_path), "--quiet"]) == status


def test_sweep_exit_status_says_a_row_lost_its_guarantee(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tubempc.cli import main
    from tubempc.commands import EXIT_GUARANTEE_LOST

    # the paper scenario: TBMPC leaves its fixed tube (as `tubempc run` says with the same status)
    assert main(["sweep", "--lambda-p", "0.96", "--out", str(tmp_path), "--quiet"]) == EXIT_GUARANTEE_LOST
    sweep = json.loads((tmp_path / "sweep.json").read_text())
    assert sweep["rows"]["TBMPC"]["steps_outside_tube"] > 0
    assert "robustness guarantee lost by TBMPC" in capsys.readouterr().err


def test_a_campaign_counts_the_runs_that_lost_a_guarantee(tmp_path: Path) -> None:
    from tubempc.analysis import montecarlo

    rough = load_config().with_overrides({"disturbance.S_r_attitude": {"value": [4e-4] * 3, "unit": "rad^2"}})
    s = montecarlo(rough, 1, tmp_path / "mc", workers=1, progress=False, max_steps=6, methods=("tbmpc",))
    row = s.methods["tbmpc"]
    assert row.runs_outside_tube == 1 and row.runs_guarantee_lost == 1 and row.runs_inside_body == 0


def test_a_reflight_checks_arrays_and_configuration_and_has_its_own_status(tmp_path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from tubempc.analysis import montecarlo
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK, EXIT_REFLIGHT_DIFFERS

    out = tmp_path / "mc"
    montecarlo(load_config(), 1, out, master_seed=3, workers=1, progress=False, max_steps=4, methods=("ffa",))
    assert EXIT_REFLIGHT_DIFFERS not in (0, 1, 2, 3, 4, 5, 130)
    assert main(["run", "--from-campaign", str(out), "--index", "0", "--out", str(tmp_path / "a")]) == EXIT_OK
    # an edited array of the run's per-step arrays in the store
    (part,) = (out / "store" / "steps").glob("part-*.parquet")
    original = part.read_bytes()
    t = pq.read_table(part)
    values = t.column("error[0]").to_numpy().copy()
    values[2] += np.float32(1e-3)  # run 0's step 2 (the only run: rows in step order)
    t = t.set_column(t.column_names.index("error[0]"), "error[0]", pa.array(values))
    pq.write_table(t, part)
    assert main(["run", "--from-campaign", str(out), "--index", "0", "--out", str(tmp_path / "b")]) == EXIT_REFLIGHT_DIFFERS
    assert json.loads((tmp_path / "b" / "refly.json").read_text())["differences"] == ["steps:ffa.error"]
    part.write_bytes(original)
    # a configuration that is not the campaign's (its hash)
    manifest = json.loads((out / "campaign.json").read_text())
    (out / "campaign.json").write_text(json.dumps({**manifest, "config_hash": "0" * 64}))
    assert main(["run", "--from-campaign", str(out), "--index", "0", "--out", str(tmp_path / "c")]) == EXIT_REFLIGHT_DIFFERS
    assert json.loads((tmp_path / "c" / "refly.json").read_text())["differences"][0].startswith("config.toml")


# --- 3. results folders that re-open anywhere -------------------------------------------------------


def _own_mission(tmp_path: Path) -> Path:
    (tmp_path / "mission" / "bodies").mkdir(parents=True)
    save_shape(tmp_path / "mission" / "bodies" / "rock.obj", ellipsoid_shape([260.0, 220.0, 180.0], 8, 0.02, 4), unit="m")
    return _write(
        tmp_path / "mission",
        '[asteroid]\nshape = "bodies/rock.obj"\nshape_unit = "m"\ndensity = "1500 kg/m^3"\n'
        '[constraints]\nglide_slope_apex = "site"\nglide_slope_axis = "normal"\n'
        '[boundary]\nterminal = "site"\nsite_latitude = "-20 deg"\nsite_longitude = "120 deg"\n'
        'terminal_attitude = "boresight_down"\ninitial = "hover"\nhover_altitude = "400 m"\n',
    )


def test_a_run_folder_with_its_own_shape_re_flies_and_re_reports_elsewhere(tmp_path: Path) -> None:
    from tubempc.analysis.report import write_report
    from tubempc.analysis.runner import run_methods
    from tubempc.sim.closed_loop import simulate

    cfg = load_config(_own_mission(tmp_path))
    out = tmp_path / "results" / "run"
    summary = run_methods(cfg, ["tbmpc"], 0, out, progress=False, make_figures=False, cache_dir=out / "cache")
    assert summary.shape_file is not None
    assert summary.shape_file["sha256"] and (out / summary.shape_file["file"]).exists()
    moved = tmp_path / "elsewhere" / "copy"
    shutil.copytree(out, moved)
    shutil.rmtree(tmp_path / "mission")  # the original shape is gone
    again = load_config(moved / "config.toml")
    assert again == load_config(out / "config.toml")
    scn = build_scenario(again, cache_dir=moved / "cache")
    assert scn.shape_source.startswith(str(moved))
    rec = simulate(scn, "tbmpc", seed=0, max_steps=3)
    assert rec.statuses == ["solved"] * 3
    _, md = write_report(moved)
    text = md.read_text()
    assert "No 3D view" not in text and "Interactive in the HTML report" in text
    # an own mission is not set against the paper's numbers
    assert "paper J_p" not in text and "Not checked: these results are not of the paper's scenario" in text


def test_a_campaign_with_its_own_shape_re_flies_from_a_copy(tmp_path: Path) -> None:
    from tubempc.analysis import montecarlo
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK

    cfg = load_config(_own_mission(tmp_path))
    out = tmp_path / "results" / "mc"
    montecarlo(cfg, 1, out, workers=1, progress=False, max_steps=3, methods=("ffa",))
    assert json.loads((out / "campaign.json").read_text())["shape_file"]["sha256"]
    moved = tmp_path / "elsewhere" / "mc"
    shutil.copytree(out, moved)
    shutil.rmtree(tmp_path / "mission")
    shutil.rmtree(out)
    assert main(["run", "--from-campaign", str(moved), "--index", "0", "--out", str(tmp_path / "again")]) == EXIT_OK


# --- 6. no artefact reported as a result ------------------------------------------------------------


def test_no_convergence_envelope_is_reported_as_fitted_when_none_exists() -> None:
    from tubempc.analysis import metrics

    flat = np.r_[1.0, np.full(40, 0.5), np.full(20, 2.0)]  # never above its final quarter's largest value
    fit = metrics.fit_exponential_convergence(flat)
    assert not fit.exists and "no decay to fit" in fit.no_fit
    growing = np.linspace(1.0, 1.2, 80)
    growing[-20:] = 0.1  # the error stays near e_0 until late: the search runs to rho = 1
    fit = metrics.fit_exponential_convergence(growing)
    assert not fit.exists and "search bound" in fit.no_fit
    decaying = 0.9 ** np.arange(60) + 0.01
    fit = metrics.fit_exponential_convergence(decaying)
    assert fit.exists and fit.rho == pytest.approx(0.9, rel=1e-2)


def test_fig14_draws_no_envelope_where_none_exists() -> None:
    from tubempc.analysis import figures, metrics

    err = np.r_[1.0, np.full(40, 0.5), np.full(20, 2.0)]
    t = np.arange(err.size) * 2.0
    fig = figures.convergence(t, err, metrics.fit_exponential_convergence(err), "v - vbar")
    ax = fig.axes[0]
    labels = [line.get_label() for line in ax.get_lines()]
    assert not any("C rho^k" in label for label in labels) and any("no Theorem 2 envelope" in lb for lb in labels)
    assert any(text.get_text().startswith("no fit: ") for text in ax.texts)
    fitted = figures.convergence(
        t, 0.9 ** np.arange(60) + 0.01, metrics.fit_exponential_convergence(0.9 ** np.arange(60) + 0.01), "e"
    )
    assert any("C rho^k" in line.get_label() for line in fitted.axes[0].get_lines())
    import matplotlib.pyplot as plt

    plt.close(fig)
    plt.close(fitted)


def test_percentages_say_below_or_above() -> None:
    from tubempc.analysis.metrics import below_or_above

    assert below_or_above(-0.5) == "0.5 % above" and below_or_above(89.94) == "89.9 % below"


# --- 7. own missions start from a neutral disturbance --------------------------------------------------


def test_own_missions_get_a_neutral_disturbance_and_the_paper_scenario_keeps_its_growth(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    paper = load_config()
    assert paper.disturbance.growth_r == 2.5  # the paper scenario's own (Figs. 10-11)
    own = load_config(_write(tmp_path, "[mpc]\nhorizon = 20\n"))
    assert own.disturbance.growth_r == 1.0 and own.disturbance.growth_p == 1.0
    assert "disturbance.growth_r" in own.defaulted
    given = load_config(_write(tmp_path, "[disturbance]\ngrowth_r = 2.0\n"))
    assert given.disturbance.growth_r == 2.0
    # `tubempc run` says which disturbance an own mission got
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK

    mission = _write(tmp_path, "[disturbance]\nseed = 3\n", "short.toml")
    out = ["run", "--config", str(mission), "--method", "ffa", "--out", str(tmp_path / "o"), "--quiet", "--no-figures"]
    assert main(out) == EXIT_OK
    assert "disturbance.growth_r not given: 1, a stationary attitude disturbance" in capsys.readouterr().out
    saved = load_config(tmp_path / "o" / "config.toml")
    assert saved.disturbance.growth_r == 1.0 and saved.defaulted == ()  # the saved file is complete
    # a complete copy of the paper's file is the paper scenario, growth and all
    assert load_config(_write(tmp_path, _paper_text(), "copy.toml")) == paper


def _paper_text() -> str:
    import importlib.resources

    return importlib.resources.files("tubempc").joinpath("data", "bennu_paper.toml").read_text(encoding="utf-8")


def test_the_packaged_scenarios_keep_their_disturbance() -> None:
    growth = {name: load_config(scenario=name).disturbance.growth_r for name in ("bennu-paper", "bennu-equator")}
    assert growth == {"bennu-paper": 2.5, "bennu-equator": 1.0}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_config(scenario="itokawa-like").disturbance.growth_r == 1.0


def test_a_reduced_accuracy_reference_is_checked_and_named(monkeypatch: pytest.MonkeyPatch) -> None:
    """cvxpy's "Solution may be inaccurate" does not reach the user raw: the outcome is named
    (last_subproblem) and the solution checked against the input bounds before it counts as converged."""
    import cvxpy as cp

    from tubempc.scenario import reference

    class Inaccurate(cp.Problem):  # type: ignore[misc]
        def solve(self, *args: Any, **kwargs: Any) -> Any:
            value = super().solve(*args, **kwargs)
            warnings.warn("Solution may be inaccurate. Try another solver.", UserWarning, stacklevel=2)
            return value

        @property
        def status(self) -> str:
            status = str(super().status)
            return "optimal_inaccurate" if status == "optimal" else status

    monkeypatch.setattr(reference.cp, "Problem", Inaccurate)
    scn = build_scenario(load_config())  # warnings are errors here: none escapes
    ref = scn.reference
    assert ref.last_subproblem == "optimal_inaccurate" and ref.converged
    assert reference._within_bounds(ref.u, 0.8 * 0.55, 0.8 * 3.0)
    assert not reference._within_bounds(ref.u, 0.5 * float(np.abs(ref.u[:, :3]).max()), 3.0)
