"""The typed summaries (tubempc.results.summaries): the committed docs/benchmarks results name their kind and
format; the same files as they were written before the summaries were typed (format 0: without `kind`
and `format_version`) read as such, field for field, and still report and re-fly; a file of another
kind, a newer format or a missing or mistyped field is refused by name."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from tubempc.config import load_config
from tubempc.results.summaries import (
    FORMAT_VERSION,
    MonteCarloSummary,
    RunSummary,
    SweepSummary,
    load_summary,
    parse_summary,
    read_summary,
    summary_json,
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
