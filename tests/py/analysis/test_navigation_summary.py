"""How a run's navigation went (tubempc.analysis.metrics.navigation_summary, issue #40): the average NEES's
chi-square bounds against scipy and against sampled chi-square averages, a synthetic navigation record's
summary by hand, the report's navigation table, the run command's console text, and a short campaign
flown on navigation keeping each run's summary and the share of runs whose NEES is inside its bounds."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from tubempc import _core
from tubempc.analysis import metrics
from tubempc.results.summaries import (
    GroupErrors,
    NavigationSummary,
    RunSummary,
    SubsystemValues,
    load_summary,
    read_summary,
    write_summary,
)
from tubempc.scenario.navigation import NavigationRecord

BENCHMARKS = Path(__file__).resolve().parents[3] / "docs" / "benchmarks"


def test_nees_bounds_are_the_chi_square_quantiles_of_the_sum_over_the_steps() -> None:
    n = _core.nav.N_STATES
    assert n == 15
    for steps in (1, 7, 150):
        lo, hi = metrics.nees_bounds(steps, n)
        assert lo == pytest.approx(chi2.ppf(0.025, steps * n) / steps, rel=1e-12)
        assert hi == pytest.approx(chi2.ppf(0.975, steps * n) / steps, rel=1e-12)
        assert lo < n < hi  # the mean of chi2(n) is n
    # one step: the quantiles of chi2(15) themselves (6.262 and 27.488)
    assert metrics.nees_bounds(1, 15) == pytest.approx((6.2621, 27.4884), abs=1e-4)
    # they narrow about n as the steps grow (the average's spread shrinks as 1 / sqrt(N))
    assert (
        metrics.nees_bounds(150, n)[1] - metrics.nees_bounds(150, n)[0]
        < metrics.nees_bounds(7, n)[1] - metrics.nees_bounds(7, n)[0]
    )
    with pytest.raises(ValueError, match="steps >= 1"):
        metrics.nees_bounds(0, n)


def test_nees_bounds_hold_95_percent_of_sampled_averages_of_independent_chi_squares() -> None:
    """Averages of N independent chi2(n) samples (a consistent filter's NEES, steps independent) fall
    below and above the bounds 2.5 % of the time each; a filter whose covariance is half the truth's
    (NEES doubled) is flagged almost always."""
    rng = np.random.default_rng(40)
    steps, n, trials = 30, 15, 20000
    samples = rng.chisquare(n, size=(trials, steps))
    lo, hi = metrics.nees_bounds(steps, n)
    means = samples.mean(axis=1)
    assert np.mean(means < lo) == pytest.approx(0.025, abs=0.005)
    assert np.mean(means > hi) == pytest.approx(0.025, abs=0.005)
    tests = [metrics.nees_test(s, n) for s in samples[:200]]
    assert all(t is not None and t.steps == steps and t.dof == n and (t.lower, t.upper) == (lo, hi) for t in tests)
    assert np.mean([t.inside for t in tests if t is not None]) == pytest.approx(0.95, abs=0.05)
    overconfident = [metrics.nees_test(2.0 * s, n) for s in samples[:200]]
    assert not any(t is not None and t.inside for t in overconfident)
    assert metrics.nees_test(np.zeros(0), n) is None


def synthetic_record(samples: bool = True) -> NavigationRecord:
    """A 4-step record with a known last error, NEES, camera frames, landmarks and gauges."""
    nav = NavigationRecord.allocate(4)
    nav.error[-1] = [3.0, 4.0, 0.0, 0.0, 0.0, 0.5, 1.0, 2.0, 2.0, 0.0, 0.0, 0.0]  # 5 m, 0.5 m/s, 3 rad, 0 rad/s
    nav.error[0] = 100.0  # not the last step: not the touchdown error
    # valid NEES: finite and the filter's answer (ok or prediction only): 15, 20, 10
    nav.nees[:] = [15.0, 20.0, np.nan, 100.0, 10.0]
    nav.status = ["ok", "ok", "ok", "numerical_failure", "prediction_only"]
    # camera frames per period (the initial call takes one) and the landmarks folded in over them
    nav.samples[:, 1] = [1, 4, 0, 2, 1]
    nav.accepted[:, 1] = [10, 40, 0, 6, 8]  # per frame: 10, 10, 3, 8
    nav.accepted[:, 0] = 99  # the altimeter's: not landmarks
    nav.landmarks[:] = 50  # the last frame's before the gate: not used
    nav.gauge[:] = [[0.5, 0.2], [1.2, 0.3], [0.9, 1.0 + 1e-12], [0.1, 1.5]]
    if not samples:
        nav.samples[:] = np.nan  # a record written before the samples were kept
    return nav


def test_a_synthetic_record_gives_its_known_summary() -> None:
    s = metrics.navigation_summary(synthetic_record())
    assert s.touchdown_error == GroupErrors(position=5.0, velocity=0.5, attitude=3.0, angular_velocity=0.0)
    assert s.nees is not None
    assert (s.nees.mean, s.nees.steps, s.nees.dof) == (pytest.approx(15.0), 3, 15)
    assert (s.nees.lower, s.nees.upper) == metrics.nees_bounds(3, 15)
    assert s.nees.inside and s.nees.probability == 0.95
    assert (s.landmarks_used, s.camera_frames) == (64, 8)
    assert s.landmarks_per_frame_mean == pytest.approx(8.0)
    assert s.landmarks_per_frame_min == 3.0  # 6 landmarks over the 2 frames of step 3
    assert s.max_gauge == SubsystemValues(translation=1.2, rotation=1.5)
    assert s.steps_outside_output_tube == 2  # 1 + 1e-12 is round-off, inside
    # an inconsistent filter's NEES is outside its bounds
    nav = synthetic_record()
    nav.nees[:] = 60.0
    bad = metrics.navigation_summary(nav).nees
    assert bad is not None and not bad.inside and bad.mean == 60.0
    # a record written before the camera frames were counted: no per-frame figures, the rest as before
    old = metrics.navigation_summary(synthetic_record(samples=False))
    assert (old.camera_frames, old.landmarks_per_frame_mean, old.landmarks_per_frame_min) == (None, None, None)
    assert old.landmarks_used == 64 and old.touchdown_error == s.touchdown_error
    # no valid NEES at all: no test; the JSON leaves the absent figures out
    nav = synthetic_record(samples=False)
    nav.nees[:] = np.nan
    none = metrics.navigation_summary(nav)
    assert none.nees is None
    assert not {"nees", "camera_frames", "landmarks_per_frame_mean", "landmarks_per_frame_min"} & set(none.to_json())
    assert NavigationSummary.from_json(none.to_json()) == none


def test_the_run_metrics_carry_the_navigation_of_a_run_flown_on_it() -> None:
    """run_metrics fills ``navigation`` from the record's navigation, and leaves it None without."""
    from tubempc.results.records import RunRecord

    rec = RunRecord.allocate("ffa", 0, 4, 3)
    rec.x[:] = rec.zbar[:] = 0.0
    assert metrics.run_metrics(rec, 2.0, np.zeros(12)).navigation is None
    rec.navigation = synthetic_record()
    assert metrics.run_metrics(rec, 2.0, np.zeros(12)).navigation == metrics.navigation_summary(rec.navigation)


def _navigated_summary(tmp_path: Path) -> tuple[Path, RunSummary]:
    """The committed bennu-paper-nav run's summary with a synthetic navigation block on its ffa run only."""
    run = read_summary(BENCHMARKS / "run_bennu-paper-nav.json", RunSummary)
    nav = metrics.navigation_summary(synthetic_record())
    # the synthetic block on ffa alone (the committed run keeps its own on both methods)
    methods = {m: dataclasses.replace(r, navigation=None) for m, r in run.methods.items()}
    methods["ffa"] = dataclasses.replace(run.methods["ffa"], navigation=nav)
    run = dataclasses.replace(run, methods=methods)
    tmp_path.mkdir(parents=True, exist_ok=True)
    write_summary(tmp_path / "summary.json", run)
    return tmp_path / "summary.json", run


def test_the_report_has_a_navigation_table_only_for_a_run_flown_on_navigation(tmp_path: Path) -> None:
    from tubempc.analysis.report import write_report

    path, run = _navigated_summary(tmp_path / "nav")
    assert load_summary(path) == run
    _, md = write_report(path.parent)
    text = md.read_text()
    assert "## Navigation" in text
    header = "| method | touchdown error r (m) | v (m/s) | phi (rad) | omega (rad/s) | average NEES | 95 % bounds | inside |"
    assert header in text and "|e" not in text  # no "|" inside a Markdown cell
    lo, hi = metrics.nees_bounds(3, 15)
    assert f"| ffa | 5 | 0.5 | 3 | 0 | 15 | [{lo:.4g}, {hi:.4g}] | yes | 64 | 8 | 3 | 1.2 | 1.5 | 2 |" in text
    assert "| tbmpc | " not in text.split("## Navigation")[1].split("\n\n## ")[0]  # flown on the true state
    # the same run without navigation: no table
    (tmp_path / "plain").mkdir()
    plain = json.loads((BENCHMARKS / "run_bennu-paper-nav.json").read_text())
    for m in plain["methods"].values():
        m.pop("navigation", None)
    (tmp_path / "plain" / "summary.json").write_text(json.dumps(plain))
    _, md = write_report(tmp_path / "plain")
    assert "## Navigation" not in md.read_text()
    # a campaign flown on navigation: the share of runs whose average NEES is inside its bounds
    mc = json.loads((BENCHMARKS / "montecarlo_bennu-paper-nav.json").read_text())
    assert "nees_inside_fraction" not in mc["methods"]["ffa"]
    mc["methods"]["ffa"]["nees_inside_fraction"] = 0.97
    (tmp_path / "mc").mkdir()
    (tmp_path / "mc" / "summary.json").write_text(json.dumps(mc))
    _, md = write_report(tmp_path / "mc")
    text = md.read_text()
    assert "runs with the average NEES inside its bounds |" in text
    assert "| 97 % |" in text and "| 100/100 | - |" in text  # tbmpc's runs carry no NEES


def test_the_console_line_tells_the_navigation() -> None:
    from tubempc.commands.run import navigation_text

    s = metrics.navigation_summary(synthetic_record())
    lo, hi = metrics.nees_bounds(3, 15)
    text = navigation_text(s)
    assert "\n" not in text
    assert text.startswith("|e_r| 5 m, |e_v| 0.5 m/s at touchdown, NEES 15 in ")
    assert f"[{lo:.3g}, {hi:.3g}] (3 steps)" in text
    assert "8 landmarks/frame (min 3)" in text and "2 steps above 1" in text
    nav = synthetic_record(samples=False)
    nav.nees[:] = 60.0
    text = navigation_text(metrics.navigation_summary(nav))
    assert "NEES 60 NOT in" in text and "64 landmarks," in text


def test_a_campaign_on_navigation_keeps_each_runs_navigation_and_the_nees_share(tmp_path: Path) -> None:
    """Two short bennu-tag-nav runs: each run's result keeps its touchdown estimation error and average
    NEES, the campaign's summary the share of runs whose NEES is inside its bounds; a re-flight equals
    the record, navigation included."""
    from tubempc.analysis import montecarlo
    from tubempc.analysis.studies import campaign_run_result
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK
    from tubempc.config import load_config
    from tubempc.results.campaign_store import CampaignStore

    out = tmp_path / "mc"
    cfg = load_config(scenario="bennu-tag-nav")
    s = montecarlo(cfg, 2, out, master_seed=0, workers=1, progress=False, max_steps=3, methods=("ffa",))
    navs = []
    for i in range(2):
        result = campaign_run_result(CampaignStore(out).result(i))
        nav = result.methods["ffa"].navigation
        assert nav is not None and nav.nees is not None and nav.nees.steps == 4
        assert np.isfinite(nav.touchdown_error.position) and 0.0 < nav.touchdown_error.position < 5.0
        assert np.isfinite(nav.nees.mean) and nav.nees.mean > 0.0
        navs.append(nav)
    assert navs[0] != navs[1]  # two seeds, two flights
    fraction = s.methods["ffa"].nees_inside_fraction
    assert fraction == np.mean([n.nees.inside for n in navs if n.nees is not None])
    assert read_summary(out / "summary.json", type(s)).methods["ffa"].nees_inside_fraction == fraction
    assert main(["run", "--from-campaign", str(out), "--index", "1", "--out", str(tmp_path / "again")]) == EXIT_OK
