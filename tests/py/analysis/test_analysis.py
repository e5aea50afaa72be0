"""Monte Carlo campaign of the real closed loop (short missions), its resume, and the report."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from tubempc.analysis import montecarlo, sweep
from tubempc.analysis.report import write_report
from tubempc.analysis.runner import guarantee_lost
from tubempc.analysis.studies import campaign_run_result
from tubempc.config import load_config
from tubempc.results.campaign_store import CampaignStore
from tubempc.results.summaries import load_summary


def edit_store(folder: Path, table: str, edit: Callable[[pa.Table], pa.Table]) -> None:
    """Rewrites the one part of a campaign store's table (``runs`` or ``steps``) through ``edit``."""
    (part,) = (folder / "store" / table).glob("part-*.parquet")
    t = pq.read_table(part)
    pq.write_table(edit(t).replace_schema_metadata(t.schema.metadata), part)


def _scale(t: pa.Table, index: int, column: str, factor: float) -> pa.Table:
    values = t.column(column).to_pylist()
    row = t.column("index").to_pylist().index(index)
    values[row] *= factor
    return t.set_column(t.column_names.index(column), column, pa.array(values, type=t.column(column).type))


def test_montecarlo_summary_resume_and_report(tmp_path: Path) -> None:
    cfg = load_config()
    out = tmp_path / "mc"
    s1 = montecarlo(cfg, 3, out, master_seed=5, workers=1, progress=False, max_steps=4)
    assert s1.runs == 3 and s1.executed_now == 3 and not s1.failed_runs
    assert load_summary(out / "summary.json") == s1  # the file reads back to the summary returned
    store = CampaignStore(out)
    for m in ("tbmpc", "ffa"):
        row = s1.methods[m]
        runs = [campaign_run_result(store.result(i)).methods[m] for i in range(3)]
        jp = np.array([r.J_p for r in runs])
        assert row.J_p.mean == pytest.approx(jp.mean())
        assert row.J_p.three_sigma == pytest.approx(3 * jp.std(ddof=1))
        assert row.runs_outside_tube == sum(
            max(r.max_tube_excursion.translation, r.max_tube_excursion.rotation) > 1 for r in runs
        )
        # the vectorised counts over the store's columns are the per-run results' own
        assert row.runs_guarantee_lost == sum(bool(guarantee_lost(r)) for r in runs)
        assert row.runs_with_cone_violation == sum(r.constraint_violations.steps > 0 for r in runs)
        assert row.terminal_position_error_max_m == max(r.terminal_error.position for r in runs)
    # the three runs differ (their seeds differ) and a rerun does nothing and changes nothing
    assert len({json.dumps(store.result(i), sort_keys=True) for i in range(3)}) == 3
    before = {p.name: p.read_bytes() for p in (out / "store").rglob("*.parquet")}
    s2 = montecarlo(cfg, 3, out, master_seed=5, workers=1, progress=False, max_steps=4)
    assert s2.executed_now == 0 and s2.methods == s1.methods and s2.statistics == s1.statistics
    assert {p.name: p.read_bytes() for p in (out / "store").rglob("*.parquet")} == before
    html, md = write_report(out)
    text = md.read_text()
    assert "paper" in text and "Monte Carlo" in text and html.read_text().count("data:image/png;base64") >= 2
    # the statistics: failure bounds (0 of 3 runs: below 1 - 0.05^(1/3) = 63.2 %), the kind without a touchdown
    assert "## Failure probabilities" in text and "| ffa | tube exit | 0/3 | 0 % | 63.16 % |" in text
    assert "not evaluated: the mission ends without a touchdown" in text
    assert "## Percentiles, worst runs and drivers" in text and "fewer than 10, too few for rank correlations" in text


def test_sweep_rejects_bad_lambdas(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="lambda_p"):
        sweep(load_config(), [1.2], None, tmp_path)
    with pytest.raises(ValueError, match="as many"):
        sweep(load_config(), [0.96, 0.97], [0.98], tmp_path)


def test_report_needs_results(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"no summary\.json"):
        write_report(tmp_path)


def test_report_compares_with_the_paper_only_for_the_paper_scenario(tmp_path: Path) -> None:
    from tubempc.analysis.runner import run_methods

    for name in ("bennu-paper", "bennu-equator"):
        out = tmp_path / name
        run_methods(load_config(scenario=name), ["tbmpc"], 0, out, progress=False, make_figures=False)
        (out / "fig14_convergence_tbmpc.png").write_bytes(b"\x89PNG\r\n\x1a\n")  # a figure to caption
        _, md = write_report(out)
        text = md.read_text()
        paper = name == "bennu-paper"
        assert ("paper J_p" in text) == paper and ("16.26" in text) == paper
        assert ("not the paper scenario" in text) == (not paper)
        assert "reference converged" in text and "steps outside the tube" in text and "fallback steps" in text
        assert "states inside the body" in text
        assert "Theorem 2 envelope" in text  # the figure's caption


def test_a_campaign_run_reflies_to_the_bit_and_a_changed_record_is_caught(tmp_path: Path) -> None:
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK, EXIT_REFLIGHT_DIFFERS, EXIT_USAGE

    cfg = load_config().with_overrides({"disturbance.scale_error_p": 0.05, "disturbance.misalignment_p": "1 deg"})
    out = tmp_path / "mc"
    s = montecarlo(cfg, 2, out, master_seed=7, workers=2, progress=False, max_steps=12)
    applied = CampaignStore(out).result(1)["applied"]
    # the summary names the worst runs with their seeds; the worst by TBMPC-FFA's J_p re-flies alone
    assert s.statistics is not None
    worst = s.statistics.methods["ffa"].metrics["J_p"].worst[0]
    assert worst.seed == CampaignStore(out).row(worst.index)["seed"]
    assert main(["run", "--from-campaign", str(out), "--index", str(worst.index), "--out", str(tmp_path / "w")]) == EXIT_OK
    # the dispersions actually drawn and realised are in the record
    assert applied["max_steps"] == 12 and applied["actuators"]["scale_error_p"] == 0.05
    assert len(applied["actuators"]["scale_p"]) == 3 and applied["actuators"]["scale_p"] != [1.0, 1.0, 1.0]
    assert len(applied["realised_disturbance"]["std"]) == 12 and max(applied["realised_disturbance"]["std"]) > 0.0
    assert main(["run", "--from-campaign", str(out), "--index", "1", "--out", str(tmp_path / "again")]) == EXIT_OK
    assert json.loads((tmp_path / "again" / "refly.json").read_text())["equal"]
    # a record that does not match what the run flies is reported, metric by metric
    edit_store(out, "runs", lambda t: _scale(t, 1, "ffa.J_p", 1.0 + 1e-15))
    assert main(["run", "--from-campaign", str(out), "--index", "1", "--out", str(tmp_path / "b")]) == EXIT_REFLIGHT_DIFFERS
    assert json.loads((tmp_path / "b" / "refly.json").read_text())["differences"] == ["ffa.J_p"]
    assert main(["run", "--from-campaign", str(out), "--out", str(tmp_path / "c")]) == EXIT_USAGE


def test_report_compares_a_run_with_actuators_with_the_ideal_actuator_run(tmp_path: Path) -> None:
    """The report's comparison against the same mission computed here apart: the ideal run flown from hand-made
    overrides, terminal error and net delta-v from the records."""
    from tubempc.analysis.report import actuation_comparison
    from tubempc.analysis.runner import run_methods
    from tubempc.results import load_record
    from tubempc.scenario import build_scenario
    from tubempc.sim.closed_loop import simulate

    short = {
        "boundary.hover_altitude": "10 m",
        "mpc.t_f": "200 s",
        "boundary.touchdown_speed": "0.05 m/s",
        "tube.design_worker": "inline",
        "simulation.reference_input_fraction": 0.4,  # 10 m in 200 s
    }
    cfg = load_config(scenario="bennu-tag-osirisrex").with_overrides(short)
    out = tmp_path / "run"
    summary = run_methods(cfg, ["ffa"], 2, out, progress=False, make_figures=False)
    scn = build_scenario(cfg, cache_dir=tmp_path / "cache")
    u_max, T_max = scn.input_bounds
    ideal = build_scenario(
        cfg.with_overrides({"spacecraft.actuators": "ideal", "spacecraft.u_max": u_max, "spacecraft.T_max": T_max}),
        cache_dir=tmp_path / "cache",
    )
    base = simulate(ideal, "ffa", 2)
    act = load_record(out / "ffa.h5")[0]
    dt = cfg.mpc.dt
    want = {
        "terminal_position_error": float(np.linalg.norm(act.x[-1, :3] - scn.xf[:3])),
        "ideal_terminal_position_error": float(np.linalg.norm(base.x[-1, :3] - ideal.xf[:3])),
        "net_delta_v": dt * sum(float(np.sqrt(u @ u)) for u in act.u_delivered[:, :3]),
        "ideal_net_delta_v": dt * sum(float(np.sqrt(u @ u)) for u in base.u[:, :3]),
        "propellant": float(act.propellant.sum()),
    }
    got = actuation_comparison(out, load_config(out / "config.toml"), 2, summary.methods)["ffa"]
    for key, value in want.items():
        assert got[key] == pytest.approx(value, rel=1e-12), key
    ratio = want["terminal_position_error"] / want["ideal_terminal_position_error"]
    assert got["terminal_error_ratio"] == pytest.approx(ratio)
    assert got["net_delta_v_ratio"] == pytest.approx(want["net_delta_v"] / want["ideal_net_delta_v"])
    assert got["pulses"] == int(act.pulses.sum()) > 0 and want["propellant"] > 0.0
    text = write_report(out)[1].read_text()
    assert "## Actuators against ideal actuators" in text
    assert f"| ffa | {got['steps_outside_tube']:g} ({got['ideal_steps_outside_tube']:g}) |" in text
    assert f"| {got['terminal_error_ratio']:.4g} |" in text and f"| {got['net_delta_v_ratio']:.4g} |" in text


def test_a_campaign_stores_the_same_on_one_and_two_workers_and_on_dask(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The closed loop's campaign (3 short runs of TBMPC-FFA): the same store, to the bit (but the run
    times), from the command on one worker, from 2 local workers in batches of 2, and from a Dask
    cluster; the command prints the failure bounds at the confidence asked for."""
    import functools

    import tubempc.analysis.studies
    from tubempc.cli import main

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_campaign import contents

    monkeypatch.setattr(
        tubempc.analysis.studies, "montecarlo", functools.partial(tubempc.analysis.studies.montecarlo, max_steps=3)
    )
    args = ["montecarlo", "--runs", "3", "--method", "ffa", "--seed", "4", "--confidence", "0.9", "--quiet"]
    assert main([*args, "--workers", "1", "--percentiles", "50,95", "--out", str(tmp_path / "one")]) == 0
    text = capsys.readouterr().out
    assert "one-sided Clopper-Pearson upper bounds at 90 % confidence" in text
    assert "ffa tube_exit: 0 of 3 runs, < 53.6 % at 90 % confidence" in text  # 1 - 0.1^(1/3)
    assert "ffa touchdown: not evaluated: the mission ends without a touchdown" in text
    s = load_summary(tmp_path / "one" / "summary.json")
    assert s.statistics is not None and [p.percent for p in s.statistics.methods["ffa"].metrics["J_p"].percentiles] == [
        50.0,
        95.0,
    ]
    cfg = load_config()
    montecarlo(
        cfg, 3, tmp_path / "two", master_seed=4, workers=2, batch_size=2, methods=("ffa",), progress=False, max_steps=3
    )
    want = contents(tmp_path / "one")
    for name in ("two",):
        got = contents(tmp_path / name)
        assert got[0].equals(want[0]) and got[1].equals(want[1])
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        montecarlo(
            cfg,
            3,
            tmp_path / "dask",
            master_seed=4,
            scheduler=cluster.scheduler_address,
            methods=("ffa",),
            progress=False,
            max_steps=3,
        )
    got = contents(tmp_path / "dask")
    assert got[0].equals(want[0]) and got[1].equals(want[1])
