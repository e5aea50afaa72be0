"""The claims table is computed from a results folder: a real run's claims, then the same folder with
a claim made false (a step outside TBMPC-FFA's tube) reads "no" in both reports."""

from __future__ import annotations

import json
from pathlib import Path

from tubempc.claims import paper_claims
from tubempc.cli import EXIT_OK, main
from tubempc.report import write_report


def _verdicts(run_dir: Path, sweep_dir: Path | None = None) -> dict[str, str]:
    return {c.claim: c.verdict for c in paper_claims(run_dir, sweep_dir)}


def test_claims_are_computed_from_the_results_and_a_failing_claim_reads_no(tmp_path: Path) -> None:
    run = tmp_path / "run"
    assert main(["run", "--out", str(run), "--quiet", "--no-figures"]) == EXIT_OK
    summary = json.loads((run / "summary.json").read_text())
    t, f = summary["methods"]["tbmpc"], summary["methods"]["ffa"]
    v = _verdicts(run)
    assert v["TBMPC-FFA stays inside its tube"] == ("yes" if f["steps_outside_tube"] == 0 else "no")
    assert v["TBMPC-FFA uses more attitude torque (J_r higher)"] == ("yes" if f["J_r"] > t["J_r"] else "no")
    assert v["TBMPC's trajectory partly leaves its fixed tube"] == ("yes" if t["steps_outside_tube"] else "no")
    assert v["J_p grows with lambda"] == "not measured"  # no sweep in the folder

    f["steps_outside_tube"] = 2  # the folder now says TBMPC-FFA left its tube
    (run / "summary.json").write_text(json.dumps(summary))
    assert _verdicts(run)["TBMPC-FFA stays inside its tube"] == "no"
    html, md = write_report(tmp_path)
    line = next(ln for ln in md.read_text().splitlines() if ln.startswith("| TBMPC-FFA stays inside its tube"))
    assert line.rstrip(" |").endswith("no") and "2 steps outside" in line
    assert "<td>TBMPC-FFA stays inside its tube</td>" in html.read_text()


def test_sweep_claims_follow_the_sweep_rows(tmp_path: Path) -> None:
    def row(lam: float, jp: float, tube: float, feasible: bool) -> dict[str, object]:
        return {"lambda_p": lam, "J_p": jp, "mean_tube_half_width_x_m": tube, "tube_feasible_every_step": feasible}

    rows = {"a": row(0.9, 1.0, 0.1, False), "b": row(0.96, 1.1, 0.2, True), "c": row(0.98, 1.2, 0.3, True)}
    (tmp_path / "sweep.json").write_text(json.dumps({"rows": rows}))
    v = {c.claim.split(" (")[0]: c.verdict for c in paper_claims(None, tmp_path)}
    assert v["J_p grows with lambda"] == "yes" and v["The tube grows with lambda"] == "yes"
    assert v["The tube LMI becomes infeasible below lambda ~ 0.95"] == "yes"
    rows["c"]["J_p"] = 1.05  # no longer growing
    rows["a"]["tube_feasible_every_step"] = True  # feasible below 0.95: the paper's bound not seen
    (tmp_path / "sweep.json").write_text(json.dumps({"rows": rows}))
    v = {c.claim.split(" (")[0]: c.verdict for c in paper_claims(None, tmp_path)}
    assert v["J_p grows with lambda"] == "no"
    assert v["The tube LMI becomes infeasible below lambda ~ 0.95"] == "no"
