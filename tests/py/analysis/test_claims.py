"""The claims table is computed from a results folder: a real run's claims, then the same folder with
a claim made false (a step outside TBMPC-FFA's tube) reads "no" in both reports."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc.analysis.claims import paper_claims
from tubempc.analysis.report import write_report
from tubempc.cli import main
from tubempc.commands import EXIT_GUARANTEE_LOST
from tubempc.results import load_record


def _verdicts(run_dir: Path, sweep_dir: Path | None = None) -> dict[str, str]:
    return {c.claim: c.verdict for c in paper_claims(run_dir, sweep_dir)}


def test_claims_are_computed_from_the_results_and_a_failing_claim_reads_no(tmp_path: Path) -> None:
    run = tmp_path / "run"
    # The default scenario is the paper's situation: TBMPC leaves its fixed tube (exit status 4), FFA does not.
    assert main(["run", "--out", str(run), "--quiet", "--no-figures"]) == EXIT_GUARANTEE_LOST
    summary = json.loads((run / "summary.json").read_text())
    t, f = summary["methods"]["tbmpc"], summary["methods"]["ffa"]
    assert t["steps_outside_tube"] > 0 and f["steps_outside_tube"] == 0
    v = _verdicts(run)
    assert v["TBMPC-FFA stays inside its tube"] == ("yes" if f["steps_outside_tube"] == 0 else "no")
    assert v["TBMPC-FFA uses more attitude torque (J_r higher)"] == ("yes" if f["J_r"] > t["J_r"] else "no")
    assert v["TBMPC's trajectory partly leaves its fixed tube"] == ("yes" if t["steps_outside_tube"] else "no")
    assert v["J_p grows with lambda"] == "not measured"  # no sweep in the folder
    # the J_p claim says where its difference comes from; checked against the records themselves
    jp_claim = next(c for c in paper_claims(run) if c.claim.startswith("TBMPC-FFA lowers J_p"))
    found = re.search(r"90 % of the difference lies in the last (\d+) of (\d+) steps", jp_claim.measured)
    assert found is not None, jp_claim.measured
    n = int(found.group(1))
    per_step = {}
    for m in ("tbmpc", "ffa"):
        rec, _ = load_record(run / f"{m}.h5")
        per_step[m] = np.sum((rec.x[:-1, :6] - rec.zbar[:-1, :6]) ** 2, axis=1) + np.sum(rec.u[:, :3] ** 2, axis=1)
        assert per_step[m].sum() == pytest.approx(summary["methods"][m]["J_p"], rel=1e-12)
    d = per_step["tbmpc"] - per_step["ffa"]
    assert d[-n:].sum() >= 0.9 * d.sum() and (n == 1 or d[-(n - 1) :].sum() < 0.9 * d.sum())
    assert f"over steps 0-{d.size - n - 1} J_p is {per_step['tbmpc'][: d.size - n].sum():.4g} (TBMPC)" in jp_claim.measured

    f["steps_outside_tube"] = 2  # the folder now says TBMPC-FFA left its tube
    (run / "summary.json").write_text(json.dumps(summary))
    assert _verdicts(run)["TBMPC-FFA stays inside its tube"] == "no"
    html, md = write_report(tmp_path)
    line = next(ln for ln in md.read_text().splitlines() if ln.startswith("| TBMPC-FFA stays inside its tube"))
    assert line.rstrip(" |").endswith("no") and "2 steps outside" in line
    assert "<td>TBMPC-FFA stays inside its tube</td>" in html.read_text()
    # the paper scenario's report explains the differences where the decisions now are
    assert 'docs/decisions.md ("Readings of the paper"' in md.read_text() and "README.md (" not in md.read_text()


#: A sweep written by ``tubempc sweep`` (before summaries named their kind and format: format 0).
SWEEP = Path(__file__).resolve().parents[3] / "docs" / "benchmarks" / "sweep_bennu-paper.json"


def test_sweep_claims_follow_the_sweep_rows(tmp_path: Path) -> None:
    written = json.loads(SWEEP.read_text())
    template = next(r for r in written["rows"].values() if "lambda_p" in r)

    def row(lam: float, jp: float, tube: float, feasible: bool, outside: int = 0) -> dict[str, object]:
        return {
            **template,
            "lambda_p": lam,
            "J_p": jp,
            "mean_tube_half_width_x_m": tube,
            "tube_feasible_every_step": feasible,
            "tube_design_failures": 0 if feasible else 2,
            "tube_uncertified_steps": 0,
            "steps_outside_tube": outside,
        }

    limit = "lambda has a lower limit below which the tube fails"
    rows = {
        "a": row(0.9, 1.0, 0.1, False),
        "b": row(0.96, 1.1, 0.2, True),
        "c": row(0.97, 1.15, 0.25, True),
        "d": row(0.98, 1.2, 0.3, True),
    }
    (tmp_path / "sweep.json").write_text(json.dumps({**written, "rows": rows}))
    claims = {c.claim.split(" (")[0]: c for c in paper_claims(None, tmp_path)}
    assert claims["J_p grows with lambda"].verdict == "yes" and claims["The tube grows with lambda"].verdict == "yes"
    assert claims[limit].verdict == "yes" and "LMI infeasible at lambda_p 0.9" in claims[limit].measured
    assert "holds for every lambda_p >= 0.96" in claims[limit].measured
    rows["a"]["J_p"] = 2.0  # outside Table 3's lambdas: not part of the trend
    rows["d"]["J_p"] = 1.05  # no longer growing
    rows["a"]["tube_design_failures"] = 0  # feasible and held below 0.95: the paper's limit not seen
    rows["a"]["tube_uncertified_steps"] = 4  # (steps on the last certified tube are reported, not a failure)
    (tmp_path / "sweep.json").write_text(json.dumps({**written, "rows": rows}))
    claims = {c.claim.split(" (")[0]: c for c in paper_claims(None, tmp_path)}
    assert claims["J_p grows with lambda"].verdict == "no"
    assert claims[limit].verdict == "no" and "LMI feasible at every step" in claims[limit].measured
    assert "steps on the last certified tube at lambda_p 0.9 (4)" in claims[limit].measured
    rows["a"]["steps_outside_tube"] = 3  # feasible but left: the tube fails below the limit
    (tmp_path / "sweep.json").write_text(json.dumps({**written, "rows": rows}))
    claims = {c.claim.split(" (")[0]: c for c in paper_claims(None, tmp_path)}
    assert claims[limit].verdict == "yes" and "tube left at lambda_p 0.9 (3 steps)" in claims[limit].measured
    rows["c"]["steps_outside_tube"] = 1  # a lambda at or above 0.95 fails: no
    (tmp_path / "sweep.json").write_text(json.dumps({**written, "rows": rows}))
    claims = {c.claim.split(" (")[0]: c for c in paper_claims(None, tmp_path)}
    assert claims[limit].verdict == "no" and "holds for every lambda_p >= 0.98" in claims[limit].measured


def test_the_papers_scenario_under_physics_is_recognised_with_its_dispersions(tmp_path: Path) -> None:
    """The report checks the paper's claims under physics on bennu-paper-physical in either plant, whatever its
    dispersions (a campaign's draws are physics too), and on nothing that changes the paper's mission."""
    from tubempc.analysis.report import paper_under_physics
    from tubempc.config import load_config

    def saved(cfg: Any, name: str) -> Path:
        folder = tmp_path / name
        folder.mkdir()
        cfg.save(folder / "config.toml")
        return folder

    paper = load_config(scenario="bennu-paper-physical")
    assert paper_under_physics(saved(paper, "paper"))
    assert paper_under_physics(saved(paper.with_overrides({"simulation.plant": "basilisk"}), "basilisk"))
    wider = paper.with_overrides({"physical.mass_error_dispersion": 0.01, "disturbance.scale_error_r": 0.0})
    assert paper_under_physics(saved(wider, "wider"))
    assert not paper_under_physics(saved(paper.with_overrides({"identification.lambda_p": 0.97}), "lambda"))
    assert not paper_under_physics(saved(load_config(scenario="bennu-tag-physical"), "tag"))
    assert not paper_under_physics(saved(load_config(), "drawn"))
