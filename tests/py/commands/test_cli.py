"""The command line: clean errors with documented exit statuses, the guarantee in the summary and the status."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tubempc.cli import main
from tubempc.commands import EXIT_GUARANTEE_LOST, EXIT_INPUT, EXIT_OK
from tubempc.config import load_config


def test_bad_option_value_names_the_option(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["run", "--seed", "-5"])
    assert info.value.code == 2
    assert "argument --seed: expected a non-negative integer, got -5" in capsys.readouterr().err


def test_input_errors_are_messages_with_file_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[mpc]\nhorizon = "thirty"\n', encoding="utf-8")
    assert main(["run", "--config", str(bad), "--out", str(tmp_path / "o")]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert err.startswith("tubempc: error: ") and str(bad) in err and "mpc.horizon" in err and "Traceback" not in err
    assert main(["run", "--scenario", "nope", "--out", str(tmp_path / "o")]) == EXIT_INPUT
    assert "unknown scenario 'nope'" in capsys.readouterr().err
    missing = ["run", "--shape", str(tmp_path / "missing.obj"), "--shape-unit", "m", "--out", str(tmp_path / "o")]
    assert main(missing) == EXIT_INPUT
    err = capsys.readouterr().err
    assert "missing.obj" in err and "asteroid.shape" in err  # the file and the field that names it
    # a configuration's missing shape names the configuration file and the field
    cfg = tmp_path / "lost.toml"
    cfg.write_text('[asteroid]\nshape = "nowhere.obj"\nshape_unit = "m"\n', encoding="utf-8")
    assert main(["run", "--config", str(cfg), "--out", str(tmp_path / "o2")]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert str(cfg) in err and "asteroid.shape" in err and "nowhere.obj" in err


def test_unwritable_output_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["export-scenario", "--out", str(blocker / "sub")]) == EXIT_INPUT
    assert str(blocker) in capsys.readouterr().err


def test_debug_shows_the_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[mpc]\nhorizon = "thirty"\n', encoding="utf-8")
    with pytest.raises(ValueError, match=r"mpc\.horizon"):
        main(["--debug", "run", "--config", str(bad)])


def test_lost_guarantee_is_reported_and_sets_the_exit_status(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A disturbance far beyond the prior: TBMPC's fixed tube is left; the summary and status say so."""
    cfg = tmp_path / "rough.toml"
    cfg.write_text('[disturbance]\nS_r_attitude = { value = [4e-4, 4e-4, 4e-4], unit = "rad^2" }\n', encoding="utf-8")
    status = main(
        ["run", "--config", str(cfg), "--method", "tbmpc", "--out", str(tmp_path / "o"), "--quiet", "--no-figures"]
    )
    out = capsys.readouterr()
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    outside = summary["methods"]["tbmpc"]["steps_outside_tube"]
    assert outside > 0 and status == EXIT_GUARANTEE_LOST
    assert f"steps outside the tube {outside}" in out.out and "guarantee lost by tbmpc" in out.err
    assert "<= 1 inside the tube, > 1 outside" in out.out and "reference: converged" in out.out


def test_partial_config_says_which_fields_are_defaults(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "short.toml"
    cfg.write_text("[disturbance]\nseed = 3\ngrowth_r = 1.0\n", encoding="utf-8")
    assert (
        main(["run", "--config", str(cfg), "--method", "tbmpc", "--out", str(tmp_path / "o"), "--quiet", "--no-figures"])
        == EXIT_OK
    )
    assert "taken from the packaged paper scenario" in capsys.readouterr().out


def test_module_entry_point_exit_status(tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "tubempc", "run", "--scenario", "nope"],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert r.returncode == EXIT_INPUT and "unknown scenario" in r.stderr and "Traceback" not in r.stderr


def test_a_runaway_configuration_is_announced_before_it_starts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "fine.toml"  # 6000 steps of 0.1 s; the missing shape stops it right after the warning
    cfg.write_text('[mpc]\ndt = "0.1 s"\n[asteroid]\nshape = "missing.obj"\nshape_unit = "m"\n', encoding="utf-8")
    assert main(["run", "--config", str(cfg), "--out", str(tmp_path / "o"), "--quiet"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert "warning: 6000 control steps per run" in err and "Ctrl-C stops" in err


def test_ctrl_c_stops_the_run_with_130_and_no_leak_report(tmp_path: Path) -> None:
    """SIGINT during a run ends the command with status 130, long before the run would end, and leaves no
    semaphore for the resource tracker to report. Independent of timing: on a loaded machine the signal
    waits for the main thread to return from the C++ call it is in (a QP or the integrator, milliseconds
    alone, seconds under load), so the bound is the run's remaining length (minutes), not a second."""
    import signal
    import time

    # A test run started in the background of a shell without job control inherits SIGINT ignored, and
    # Python then installs no handler for it: the child gets the default disposition back, as a terminal's has.
    proc = subprocess.Popen(
        [sys.executable, "-m", "tubempc", "run", "--out", str(tmp_path / "o"), "--quiet", "--no-figures", "--method", "ffa"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 120
        while not (tmp_path / "o" / "config.toml").exists():  # written once the scenario is built
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        time.sleep(0.5)  # inside the closed loop
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 130 and "interrupted" in err
    assert "leaked semaphore" not in err and "resource_tracker" not in err, err
    assert not (tmp_path / "o" / "summary.json").exists()  # stopped, not finished


def test_a_figure_that_cannot_be_drawn_never_loses_the_run(tmp_path: Path) -> None:
    from tubempc.analysis.runner import save_figures
    from tubempc.config import load_config
    from tubempc.scenario import build_scenario
    from tubempc.sim.closed_loop import simulate

    scn = build_scenario(load_config(), cache_dir=tmp_path / "cache")
    rec = simulate(scn, "tbmpc", seed=0, max_steps=4)
    rec.x = rec.zbar[: rec.x.shape[0]].copy()  # no velocity error at all: fig14's fit is undefined
    with pytest.warns(RuntimeWarning, match="fig14_convergence_tbmpc.png: figure not drawn"):
        failed = save_figures(scn, {"tbmpc": rec}, tmp_path)
    assert list(failed) == ["fig14_convergence_tbmpc.png"] and (tmp_path / "fig03_trajectory.png").exists()


def test_bench_integrator_orders_rk4_by_its_substeps(tmp_path: Path) -> None:
    out = tmp_path / "integrator.json"
    args = ["bench", "integrator", "--intervals", "10", "--substeps", "1,4", "--dopri-rtol", "1e-10", "--repeats", "1"]
    assert main([*args, "--json", str(out)]) == EXIT_OK
    rows = json.loads(out.read_text())["candidates"]
    coarse, fine = rows["rk4, 1 substeps"], rows["rk4, 4 substeps"]
    # fourth order: 4x the substeps, ~256x smaller one-step error (a wrong reference would not show it)
    assert fine["one_step_max"]["velocity_m_s"] < coarse["one_step_max"]["velocity_m_s"] / 30.0
    assert fine["evaluations_per_interval"] == 4 * coarse["evaluations_per_interval"] == 16
    assert rows["dopri5, rtol 1e-10"]["final"]["position_m"] < 1e-6


def test_bench_controller_reports_the_whole_step(tmp_path: Path) -> None:
    out = tmp_path / "controller.json"
    assert main(["bench", "controller", "--method", "tbmpc", "--json", str(out)]) == EXIT_OK
    d = json.loads(out.read_text())
    row = d["methods"]["tbmpc"]
    assert row["controller"]["median_ms"] >= row["mpc"]["median_ms"] > 0.0
    assert row["controller"]["max_ms"] >= row["controller"]["p99_ms"] >= row["controller"]["median_ms"]
    assert d["config"]["mpc"]["horizon"] == 30 and d["machine"]["cores"] >= 1


def test_bench_actuators_agrees_with_scipy_and_contains_the_errors(tmp_path: Path) -> None:
    out = tmp_path / "actuators.json"
    assert main(["bench", "actuators", "--commands", "60", "--json", str(out)]) == EXIT_OK
    d = json.loads(out.read_text())
    a, e = d["allocation"], d["actuation_error"]
    assert a["max_x_difference_over_bounds"] < 1e-5 and a["max_objective_excess"] < 1e-8
    assert sum(a["statuses"].values()) == 60 and a["statuses"]["ok"] > 0
    assert max(e["worst_sampled_over_bound"]) <= 1.0
    healthy, failed = d["achievable_box"]["healthy_half_width_B"], d["achievable_box"]["one_failure_half_width_B"]
    assert all(0.0 < f <= h for f, h in zip(failed, healthy, strict=True))


def test_bench_controller_pools_repeated_flights_on_navigation(tmp_path: Path) -> None:
    """--repeats flies the same steps again: each distribution pools the flights, and every flight's own ratio
    of controller + estimator to the full-state controller is reported beside the pooled one."""
    short = {"mpc.t_f": "80 s", "boundary.hover_altitude": "10 m", "tube.design_worker": "inline"}
    cfg = load_config(scenario="bennu-tag-nav").with_overrides(short)
    cfg.save(tmp_path / "short.toml")
    out = tmp_path / "controller.json"
    argv = ["bench", "controller", "--config", str(tmp_path / "short.toml"), "--method", "ffa", "--repeats", "2"]
    assert main([*argv, "--json", str(out)]) == EXIT_OK
    d = json.loads(out.read_text())
    row = d["methods"]["ffa"]
    assert d["repeats"] == 2 and len(row["estimator_p99_ratio_per_flight"]) == 2
    assert all(0.0 < r < 100.0 for r in row["estimator_p99_ratio_per_flight"])
    ce, c, e = row["controller_and_estimator"], row["controller"], row["estimator"]
    assert ce["max_ms"] <= c["max_ms"] + e["max_ms"] + 1e-9 and ce["median_ms"] >= c["median_ms"]
    assert row["estimator_p99_ratio"] == ce["p99_ms"] / row["full_state_controller"]["p99_ms"]
    with pytest.raises(SystemExit, match="--repeats must be >= 1"):
        main(["bench", "controller", "--repeats", "0"])


def test_bench_actuation_reports_the_terminal_error_ratio_over_seeds(tmp_path: Path) -> None:
    """--seeds flies more seeds both ways: the first is the seed the other figures are of, each ratio is the
    actuated over the ideal error of the same seed, and the summary follows from the lists."""
    from tubempc.benchmarks.actuation import seed_statistics

    s = seed_statistics([2.0, 1.0, 3.0, 8.0], [1.0, 1.0, 1.0, 2.0])
    assert s["terminal_error_ratio"] == [2.0, 1.0, 3.0, 4.0] and s["terminal_error_ratio_median"] == 2.5
    assert s["share_within_2x"] == 0.5 and s["median_error_ratio"] == 2.5 / 1.0
    assert s["rms_error_ratio"] == pytest.approx(np.sqrt((4 + 1 + 9 + 64) / (1 + 1 + 1 + 4)), rel=1e-15)
    short = {
        "boundary.hover_altitude": "10 m",
        "mpc.t_f": "200 s",
        "boundary.touchdown_speed": "0.05 m/s",
        "tube.design_worker": "inline",
        "simulation.reference_input_fraction": 0.4,  # 10 m in 200 s
    }
    cfg = load_config(scenario="bennu-tag-osirisrex").with_overrides(short)
    cfg.save(tmp_path / "short.toml")
    out = tmp_path / "actuation.json"
    argv = ["bench", "actuation", "--config", str(tmp_path / "short.toml"), "--method", "ffa", "--seeds", "2"]
    assert main([*argv, "--json", str(out)]) == EXIT_OK
    d = json.loads(out.read_text())
    row = d["methods"]["ffa"]
    o = row["over_seeds"]
    assert d["seeds"] == 2 and len(o["terminal_error_ratio"]) == 2
    assert o["terminal_position_error_m"][0] == row["actuators"]["terminal_position_error_m"]
    assert o["ideal_terminal_position_error_m"][0] == row["ideal"]["terminal_position_error_m"]
    assert o["terminal_position_error_m"][1] != o["terminal_position_error_m"][0]  # another seed's disturbance
    assert o["terminal_error_ratio"][0] == row["terminal_error_ratio"]
    with pytest.raises(SystemExit, match="--seeds must be >= 1"):
        main([*argv[:-1], "0"])
