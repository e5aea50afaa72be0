"""The typed summaries (tubempc.results.summaries): the committed docs/benchmarks results name their kind and
format; the same files as they were written before the summaries were typed (format 0: without `kind`
and `format_version`) read as such, field for field, and still report and re-fly; a file of another
kind, a newer format or a missing or mistyped field is refused by name."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from tubempc.config import load_config
from tubempc.results.summaries import (
    FORMAT_VERSION,
    CampaignMethodResult,
    CampaignRunResult,
    GroupErrors,
    MonteCarloSummary,
    NavigationSummary,
    NeesTest,
    RunSummary,
    SubsystemValues,
    SweepSummary,
    load_summary,
    parse_summary,
    read_summary,
    summary_json,
    write_summary,
)

BENCHMARKS = Path(__file__).resolve().parents[3] / "docs" / "benchmarks"
KINDS = {"run": RunSummary, "sweep": SweepSummary, "montecarlo": MonteCarloSummary}
COMMITTED = sorted(p for p in BENCHMARKS.glob("*.json") if p.name.split("_")[0] in KINDS)


def as_format_0(source: Path, target: Path) -> dict[str, object]:
    """Writes `source` to `target` as it was written before the summaries named kind and format."""
    data = json.loads(source.read_text())
    data.pop("kind", None)
    data.pop("format_version", None)
    target.write_text(json.dumps(data))
    return dict(data)


def test_the_committed_results_name_their_kind_and_format() -> None:
    assert {p.name.split("_")[0] for p in COMMITTED} == set(KINDS)
    for p in COMMITTED:
        data = json.loads(p.read_text())
        assert (data["kind"], data["format_version"]) == (p.name.split("_")[0], FORMAT_VERSION), p
        assert isinstance(load_summary(p), KINDS[data["kind"]])


@pytest.mark.parametrize("path", COMMITTED, ids=lambda p: p.stem)
def test_a_version_less_file_reads_as_format_0_and_keeps_every_field(path: Path, tmp_path: Path) -> None:
    data = as_format_0(path, tmp_path / path.name)
    s = load_summary(tmp_path / path.name)
    assert isinstance(s, KINDS[path.name.split("_")[0]]) and s.format_version == 0
    # written again: the same fields with the same values (floats to the bit), plus kind and format
    assert summary_json(s) == {**data, "kind": s.KIND, "format_version": FORMAT_VERSION}
    again = parse_summary(json.loads(json.dumps(summary_json(s))))
    assert again == s and again.format_version == FORMAT_VERSION


def test_a_file_of_another_kind_or_format_or_with_a_bad_field_is_refused_by_name(tmp_path: Path) -> None:
    run = json.loads((BENCHMARKS / "run_bennu-paper.json").read_text())
    f = tmp_path / "summary.json"

    def write(data: dict[str, object]) -> Path:
        f.write_text(json.dumps(data))
        return f

    with pytest.raises(ValueError, match="a run summary, not a sweep summary"):
        read_summary(write(run), SweepSummary)
    with pytest.raises(ValueError, match="format_version 2 is not one this tubempc reads"):
        load_summary(write({**run, "kind": "run", "format_version": FORMAT_VERSION + 1}))
    with pytest.raises(ValueError, match="kind 'runs'"):
        load_summary(write({**run, "kind": "runs", "format_version": FORMAT_VERSION}))
    # a version-1 file says its kind: a run's fields under the sweep's kind lack the sweep's
    with pytest.raises(ValueError, match="missing field 'rows'"):
        load_summary(write({**run, "kind": "sweep", "format_version": FORMAT_VERSION}))
    bad = json.loads(json.dumps(run))
    bad["methods"]["ffa"]["steps_outside_tube"] = "none"
    with pytest.raises(ValueError, match=r"methods\.ffa\.steps_outside_tube: expected int"):
        load_summary(write(bad))
    del bad["methods"]["ffa"]["J_r"]
    with pytest.raises(ValueError, match=r"methods\.ffa: missing field 'J_r'"):
        load_summary(write(bad))
    with pytest.raises(ValueError, match="not a tubempc summary"):
        load_summary(write({"gravity": 1}))


def test_a_results_folder_of_format_0_files_still_reports(tmp_path: Path) -> None:
    from tubempc.analysis.claims import paper_claims
    from tubempc.analysis.report import write_report

    as_format_0(BENCHMARKS / "run_bennu-paper.json", tmp_path / "summary.json")
    (tmp_path / "sweep").mkdir()
    as_format_0(BENCHMARKS / "sweep_bennu-paper.json", tmp_path / "sweep" / "sweep.json")
    (tmp_path / "montecarlo").mkdir()
    as_format_0(BENCHMARKS / "montecarlo_bennu-paper.json", tmp_path / "montecarlo" / "summary.json")
    _, md = write_report(tmp_path)
    text = md.read_text()
    run = json.loads((tmp_path / "summary.json").read_text())
    mc = json.loads((tmp_path / "montecarlo" / "summary.json").read_text())
    assert f"| ffa | {run['methods']['ffa']['J_p']:.4g} | {run['methods']['ffa']['J_r']:.4g} |" in text
    assert f"| tbmpc | {mc['methods']['tbmpc']['J_p']['mean']:.4g} | {mc['methods']['tbmpc']['J_p']['3sigma']:.4g} |" in text
    assert "| FFA lambda_p=0.96, lambda_r=0.98 |" in text
    # a Monte Carlo summary at the folder's root is reported as one (its file says so, or its keys do)
    only_mc = tmp_path / "mc_only"
    only_mc.mkdir()
    shutil.copy(tmp_path / "montecarlo" / "summary.json", only_mc / "summary.json")
    _, md = write_report(only_mc)
    assert "Monte Carlo (paper Table 4)" in md.read_text() and "Closed loop" not in md.read_text()
    # a campaign of one method beside a run of both: the claims use what the campaign flew
    mc = json.loads((tmp_path / "montecarlo" / "summary.json").read_text())
    del mc["methods"]["tbmpc"], mc["J_p_mean_reduction_percent"]
    (tmp_path / "montecarlo" / "summary.json").write_text(json.dumps(mc))
    _, md = write_report(tmp_path)
    assert f"| ffa | {mc['methods']['ffa']['J_p']['mean']:.4g} |" in md.read_text()
    claims = {c.claim: c.measured for c in paper_claims(tmp_path, None, tmp_path / "montecarlo")}
    assert "Monte Carlo" not in claims["TBMPC's trajectory partly leaves its fixed tube"]
    assert f"of {mc['runs']} Monte Carlo runs" in claims["TBMPC-FFA stays inside its tube"]


def test_a_campaign_with_a_format_0_summary_reports_and_re_flies(tmp_path: Path) -> None:
    from tubempc.analysis import montecarlo
    from tubempc.analysis.report import write_report
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK

    out = tmp_path / "mc"
    s = montecarlo(load_config(), 1, out, master_seed=2, workers=1, progress=False, max_steps=3, methods=("ffa",))
    data = json.loads((out / "summary.json").read_text())
    assert data["kind"] == "montecarlo" and data["format_version"] == FORMAT_VERSION
    del data["kind"], data["format_version"]  # as written before the summaries were typed
    (out / "summary.json").write_text(json.dumps(data))
    old = read_summary(out / "summary.json", MonteCarloSummary)
    assert old.format_version == 0 and old == s
    _, md = write_report(out)
    assert f"| ffa | {s.methods['ffa'].J_p.mean:.4g} |" in md.read_text()
    assert main(["run", "--from-campaign", str(out), "--index", "0", "--out", str(tmp_path / "again")]) == EXIT_OK


def _navigation() -> NavigationSummary:
    return NavigationSummary(
        touchdown_error=GroupErrors(position=0.12, velocity=3e-3, attitude=1e-4, angular_velocity=2e-5),
        nees=NeesTest(mean=14.2, steps=151, dof=15, probability=0.95, lower=13.67, upper=16.39, inside=True),
        landmarks_used=2416,
        camera_frames=151,
        landmarks_per_frame_mean=16.0,
        landmarks_per_frame_min=9.0,
        max_gauge=SubsystemValues(translation=0.4, rotation=0.7),
        steps_outside_output_tube=0,
    )


def test_a_run_summary_with_navigation_round_trips_and_one_without_is_unchanged(tmp_path: Path) -> None:
    """A run flown on navigation keeps its NavigationSummary through the file; a run without (or a file
    written before the field existed: every committed run) reads navigation = None, and writes no key."""
    for path in (p for p in COMMITTED if p.name.startswith("run_")):
        data = json.loads(path.read_text())
        run = read_summary(path, RunSummary)
        # a run flown on navigation (run_bennu-paper-nav.json) keeps it; the others read None
        assert all((m.navigation is None) == ("navigation" not in data["methods"][k]) for k, m in run.methods.items())
        assert summary_json(run) == data  # no "navigation": None is left out of the file
    run = read_summary(BENCHMARKS / "run_bennu-paper-nav.json", RunSummary)
    nav = _navigation()
    run = dataclasses.replace(run, methods={m: dataclasses.replace(r, navigation=nav) for m, r in run.methods.items()})
    f = write_summary(tmp_path / "summary.json", run)
    data = json.loads(f.read_text())
    assert data["methods"]["ffa"]["navigation"]["nees"]["upper"] == 16.39
    assert data["methods"]["ffa"]["navigation"]["touchdown_error"]["position"] == 0.12
    again = read_summary(f, RunSummary)
    assert again == run and again.methods["tbmpc"].navigation == nav
    # the optional figures absent: left out, and read back as None
    bare = dataclasses.replace(
        nav, nees=None, camera_frames=None, landmarks_per_frame_mean=None, landmarks_per_frame_min=None
    )
    assert set(bare.to_json()) == {"touchdown_error", "landmarks_used", "max_gauge", "steps_outside_output_tube"}
    assert NavigationSummary.from_json(bare.to_json()) == bare
    # a mistyped field is named
    data["methods"]["ffa"]["navigation"]["nees"]["inside"] = "yes"
    f.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"methods\.ffa\.navigation\.nees\.inside: expected bool"):
        load_summary(f)


def test_a_campaign_run_keeps_its_navigation_and_the_summary_its_nees_share() -> None:
    mc = json.loads((BENCHMARKS / "montecarlo_bennu-paper-nav.json").read_text())
    old = parse_summary(mc)
    assert isinstance(old, MonteCarloSummary)
    assert all(m.nees_inside_fraction is None for m in old.methods.values())
    assert summary_json(old) == mc
    new = dataclasses.replace(
        old, methods={**old.methods, "ffa": dataclasses.replace(old.methods["ffa"], nees_inside_fraction=0.93)}
    )
    assert summary_json(new)["methods"]["ffa"]["nees_inside_fraction"] == 0.93
    assert parse_summary(json.loads(json.dumps(summary_json(new)))) == new
    run = read_summary(BENCHMARKS / "run_bennu-paper-nav.json", RunSummary)
    kept = CampaignMethodResult.of(dataclasses.replace(run.methods["ffa"], navigation=_navigation()))
    result = CampaignRunResult(methods={"ffa": kept}, applied={"seed": 1})
    back = CampaignRunResult.from_json(json.loads(json.dumps(result.to_json())))
    assert back == result and back.methods["ffa"].navigation == _navigation()
