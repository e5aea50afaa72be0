"""``tubempc bench instructions``: the reading of callgrind's combined profile and the figures made of it."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from tubempc.benchmarks.instructions import GRAVITY, LDLT, SENSORS, _method_figures, _per_step, parse_callgrind

# Two parts as callgrind 3.19 writes them with --combine-dumps=yes (names compressed once for the file,
# relative positions, a call inside the gravity to itself, a call to the gravity from the MPC).
PROFILE = """# callgrind format
version: 1
creator: callgrind-3.19.0
pid: 1
cmd:  closed_loop scenario.txt --instructions
part: 1

desc: Timerange: Basic block 0 - 10
desc: Trigger: Client Request: ffa controller 0

positions: line
events: Ir
summary: 1000

ob=(1) closed_loop
fl=(1) ???
fn=(1) main
0 100
cfl=(1)
cfn=(2) tubempc::mpc::TubeMPC::step(int, Eigen::Ref<Eigen::Matrix<double, -1, 1> const> const&, tubempc::mpc::Tube const&)
calls=1 0
0 900

fn=(2)
0 100
cfn=(3) tubempc::gravity::PolyhedronGravity::evaluate(Eigen::Matrix<double, 3, 1> const&, GravitySample&) const
calls=3 0
+2 600
cfn=(4) tubempc::mpc::PartialLdlt::refactorize(Eigen::SparseMatrix<double, 0, int> const&, Eigen::Ref<> const&)
calls=2 0
* 200

fn=(3)
0 550
cfn=(3)
calls=1 0
0 50

totals: 1000
part: 2

desc: Timerange: Basic block 10 - 20
desc: Trigger: Client Request: ffa controller 1

positions: line
events: Ir
summary: 400

fn=(1)
0 150
cfn=(2)
calls=1 0
0 250

fn=(2)
0 150
cfn=(3)
calls=1 0
0 100

totals: 400
part: 3

desc: Trigger: Program termination

positions: line
events: Ir
summary: 0

totals: 0
"""


def test_parse_callgrind_parts_calls_and_inclusive_instructions(tmp_path: Path) -> None:
    path = tmp_path / "callgrind.out"
    path.write_text(PROFILE, encoding="utf-8")
    parts = parse_callgrind(path, (GRAVITY, LDLT, SENSORS))
    assert [p.label for p in parts] == ["ffa controller 0", "ffa controller 1", "Program termination"]
    assert [p.instructions for p in parts] == [1000, 400, 0]
    # the gravity's call to itself is not counted twice; the compressed name (3) is resolved in part 2
    assert parts[0].count(GRAVITY) == (3, 600)
    assert parts[0].count(LDLT) == (2, 200)
    assert parts[1].count(GRAVITY) == (1, 100)
    assert parts[1].count(LDLT) == (0, 0)
    assert parts[0].count(SENSORS) == (0, 0)


def test_figures_per_step_worst_step_and_what_it_did(tmp_path: Path) -> None:
    path = tmp_path / "callgrind.out"
    path.write_text(PROFILE, encoding="utf-8")
    parts = _per_step(parse_callgrind(path, (GRAVITY, LDLT, SENSORS)), "ffa", 2)
    assert list(parts) == ["controller"]
    counts = {
        "scp_iterations": [2, 1],
        "active_set_solves": [2, 1],
        "active_set_iterations": [5, 1],
        "active_set_failures": [0, 0],
        "qp_iterations": [0, 0],
        "model_evaluations": [30, 1],
        "mpc_status": [0, 0],
    }
    f = _method_figures(parts, {"step_counts": counts})
    c = f["components"]["controller"]
    assert (c["median"], c["max"]) == (700.0, 1000.0)
    assert c["p99"] == pytest.approx(float(np.percentile([1000, 400], 99)))
    w = c["worst"]
    assert (w["step"], w["instructions"], w["gravity_evaluations"], w["gravity_instructions"]) == (0, 1000, 3, 600)
    assert (w["scp_iterations"], w["active_set_iterations"], w["model_evaluations"], w["ldlt_instructions"]) == (
        2,
        5,
        30,
        200,
    )
    assert w["mpc_status"] == "Solved"
    assert c["share_gravity"] == pytest.approx(700 / 1400)
    assert f["onboard"]["max"] == 1000.0 and f["onboard"]["parts"] == ["controller"]
    # a step missing from the profile is an error, not a shorter series
    with pytest.raises(RuntimeError, match="lacks ffa controller steps"):
        _per_step(parse_callgrind(path, (GRAVITY,)), "ffa", 3)


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_bench_instructions_needs_the_instrumented_example(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Without --instructions under callgrind the example refuses to count (exit 2), so a flight is never
    reported as counted when it was not."""
    from tubempc.testing.examples import find_example

    try:
        example = find_example(None)
    except FileNotFoundError:
        pytest.skip("no closed_loop binary under build/*/")
    import subprocess

    proc = subprocess.run([str(example), "missing.txt", "--instructions"], capture_output=True, text=True, check=False)
    assert proc.returncode == 2 and "--instructions needs" in proc.stderr


# callgrind_annotate --inclusive=yes lines of a whole run (valgrind 3.19), shortened: the totals, a file-prefixed
# name, a nested call of a group's function and a name with "::" but no file prefix.
ANNOTATED = """--------------------------------------------------------------------------------
Ir
--------------------------------------------------------------------------------
1,616,856,820 (100.0%)  PROGRAM TOTALS

--------------------------------------------------------------------------------
Ir                      file:function
--------------------------------------------------------------------------------
1,614,967,954 (99.88%)  ???:main [/build/closed_loop]
  667,831,950 (41.30%)  ???:tubempc::gravity::PolyhedronGravity::evaluate(Eigen::Matrix<double, 3, 1, 0, 3, 1> const&, \
tubempc::gravity::GravitySample&) const [/build/closed_loop]
  539,389,418 (33.36%)  ???:tubempc::dynamics::propagate(tubempc::dynamics::ProximityModel const&, double, Eigen::Matrix<\
double, 13, 1, 0, 13, 1> const&) [/build/closed_loop]
  493,529,772 (30.52%)  /src/controller.cpp:tubempc::control::Controller::step(int, Eigen::Ref<> const&) [/build/closed_loop]
  1,000 (0.00%)  tubempc::nav::NavigationSystem::step(double) [/build/closed_loop]
  77 (0.00%)  ???:tubempc::control::Controller::setup_library() [/build/closed_loop]
"""


def test_runcost_reads_the_inclusive_counts_of_its_groups() -> None:
    from tubempc.benchmarks.runcost import annotated_groups

    g = annotated_groups(ANNOTATED)
    assert g["total"] == 1_616_856_820
    assert g["polyhedral_gravity"] == 667_831_950
    assert g["truth_propagation"] == 539_389_418
    assert g["controller_steps"] == 493_529_772
    assert g["navigation"] == 1_000
    assert g["controller_setup"] == 0  # "Controller::setup_library(" is not "Controller::setup("
    with pytest.raises(ValueError, match="PROGRAM TOTALS"):
        annotated_groups("1,000 (100.0%)  ???:main [/build/closed_loop]\n")
