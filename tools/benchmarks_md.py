"""Writes docs/benchmarks.md from the JSON files in docs/benchmarks/ (the one writer of that page).

Each JSON file is what a benchmark or command wrote (`tubempc bench NAME --json docs/benchmarks/NAME.json`,
a run's summary.json, a campaign's summary.json, tools/test.sh's test_command.json); the page shows
the current figures of each, its machine, date and command. Regenerate after rerunning a benchmark:

    python tools/benchmarks_md.py            # reads docs/benchmarks/*.json, writes docs/benchmarks.md
"""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "benchmarks"


# The file each command writes into its --out folder, copied to docs/benchmarks/<name>.json.
_OUT_FILE = {"run": "summary.json", "montecarlo": "summary.json", "sweep": "sweep.json"}


def _file_name(path: str) -> str:
    """An absolute path of the machine that ran a benchmark, reduced to its file name."""
    return re.sub(r"(?<![\w.])/(?:[^\s/]+/)+([^\s/]+)", r"\1", path)


def portable_command(command: str, name: str, kind: str, d: dict[str, Any]) -> str:
    """The command as anyone can run it from the repository's root: an absolute --out folder becomes
    results/<its name>, any other absolute path its file name (the radar shape model: README, "Real
    Bennu shape model"), and a command whose figures are a file of its --out folder copies it here."""
    cmd = re.sub(r"(--out\s+)/(?:[^\s/]+/)*([^\s/]+)", r"\1results/\2", command)
    cmd = _file_name(cmd)
    shape = str(d.get("shape", "")) if kind == "gravity" else ""
    if shape.startswith("/") and "--shape" not in cmd:
        cmd = cmd.replace(" --json", f" --shape {_file_name(shape.split()[0])} --json", 1)
    out = re.search(r"--out\s+(\S+)", cmd)
    if kind in _OUT_FILE and out and "--json" not in cmd:
        cmd += f" && cp {out.group(1)}/{_OUT_FILE[kind]} docs/benchmarks/{name}.json"
    return cmd


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.3g} ms"


def _gravity(d: dict[str, Any]) -> list[tuple[str, str]]:
    rows = [
        (
            "polyhedral gravity (U, a, Hess U) per point, " + _file_name(d["shape"]),
            f"{d['tubempc_us_per_point_1_thread']:.1f} us on 1 thread, {d['tubempc_us_per_point_all_threads']:.1f} us "
            f"on {d['hardware_threads']}",
        )
    ]
    if "polyhedral_gravity_version" in d:
        rows.append(
            (
                f"ESA polyhedral-gravity {d['polyhedral_gravity_version']}, same points",
                f"{d['polyhedral_gravity_us_per_point_1_thread']:.0f} us on 1 thread ({d['ratio_1_thread']:.1f}x "
                f"slower); agreement: potential {d['max_rel_diff_potential']:.1e}, acceleration "
                f"{d['max_rel_diff_acceleration']:.1e}, gradient {d['max_rel_diff_gradient']:.1e} (max relative)",
            )
        )
    if "basilisk_version" in d:
        rows.append(
            (
                f"Basilisk {d['basilisk_version']} PolyhedralGravityModel (acceleration), same points",
                f"{d['basilisk_us_per_point_1_thread']:.0f} us on 1 thread ({d['basilisk_ratio_1_thread']:.1f}x the "
                f"time of tubempc's U, a and Hess U); agreement: potential {d['basilisk_max_rel_diff_potential']:.1e} "
                f"(max relative), acceleration {d['basilisk_max_rel_diff_acceleration']:.1e} (relative to the largest)",
            )
        )
    return rows


def _dynamics(d: dict[str, Any]) -> list[tuple[str, str]]:
    e = d["exact"]
    return [
        ("f + Jacobians (" + d["gravity"] + ")", f"{1e6 * e['f_and_jacobians_s']:.0f} us"),
        (f"linearise + discretise a {e['nodes']}-node horizon", _ms(e["horizon_s"])),
    ]


def _mpc(d: dict[str, Any]) -> list[tuple[str, str]]:
    st = d["step"]
    rows = [
        (
            f"C++ tube MPC step, Bennu mission (T = {d['T']}, N = {d['N']}), {d['statuses']}",
            f"median {_ms(st['total']['median'])}, p99 {_ms(st['total']['p99'])}, max {_ms(st['total']['max'])}",
        ),
        (
            "QP solve per QP (active set, PIQP fallback)",
            f"median {_ms(st['solve_per_qp']['median'])}, p99 {_ms(st['solve_per_qp']['p99'])}; "
            f"{d['active_set_qps']}/{d['qps']} QPs by the active set; KKT residual {d['cpp_max_kkt_residual']:.1e}",
        ),
    ]
    for name, b in d.get("baseline", {}).items():
        rows.append(
            (
                f"same QPs through {name} (wall time per QP, ratio to the core)",
                f"{_ms(b['wall_time_median'])} ({b['ratio_wall_median']:.0f}x); objective difference "
                f"median {b['median_abs_rel_objective_diff']:.1e}",
            )
        )
    return rows


def _embed(d: dict[str, Any]) -> list[tuple[str, str]]:
    c, p = d["summary"]["cpp"]["controller"], d["summary"]["python"]["call"]
    allocations = max(r["allocations_controller"] for r in d["runs"] if r["loop"] == "cpp")
    what = (
        "TBMPC-FFA controller step of the exported mission: C++ example against the same loop over the bindings, "
        f"{d['repeats']} runs"
    )
    return [
        (
            what,
            f"C++ median {_ms(c['median'])} (p99 {_ms(c['p99'])}), bindings median {_ms(p['median'])} (p99 "
            f"{_ms(p['p99'])}), ratio {d['python_over_cpp_controller_median']:.3f}; spread of the final states "
            f"{d['final_state_spread']:.1g}; heap allocations in the C++ step {allocations}",
        )
    ]


def _fuzz(d: dict[str, Any]) -> list[tuple[str, str]]:
    total: dict[str, int] = {}
    for counts in d["counts"].values():
        for k, v in counts.items():
            total[k] = total.get(k, 0) + v
    return [
        (
            f"fuzzed shape files and configs ({', '.join(d['counts'])}), {d['inputs']} inputs, seed {d['seed']}",
            ", ".join(f"{k} {v}" for k, v in total.items()) + f"; {d['wall_time_s']:.0f} s",
        )
    ]


def _plant(d: dict[str, Any]) -> str:
    """Who propagated the truth of a run's or campaign's summary (absent: the project's plant)."""
    return ", in Basilisk" if d.get("plant") == "basilisk" else ""


def _plant_bench(d: dict[str, Any]) -> list[tuple[str, str]]:
    m, ms = d["max_difference"], d["ms_per_step"]
    return [
        (
            f"Basilisk {d['bsk']} plant against the project's, {d['steps']} steps open loop, {_file_name(d['scenario'])}",
            f"position <= {m['position_m']:.2g} m ({d['position_over_semi_axis']:.1e} of TBMPC's position semi-axis "
            f"{d['tube_semi_axis_m']:.3g} m), velocity <= {m['velocity_m_s']:.2g} m/s, attitude <= {m['attitude_rad']:.2g} "
            f"rad; per control step {ms['basilisk']:.3g} ms against {ms['project']:.3g} ms "
            f"({d['basilisk_over_project']:.2f}x)",
        )
    ]


def _run(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    rows = []
    for m, r in d["methods"].items():
        st = r["step_time"]
        rows.append(
            (
                f"closed loop {m}, {name.removeprefix('run_')}, seed {d['seed']}{_plant(d)}",
                f"J_p {r['J_p']:.4g}, J_r {r['J_r']:.4g}, terminal error "
                f"{1e3 * r['terminal_error']['position']:.3g} mm, "
                f"steps outside the tube {r['steps_outside_tube']}, fallbacks {r.get('fallback_steps', 0)}; step "
                f"median {st['step']['median_ms']:.3g} ms (tube {st['tube']['median_ms']:.3g}, MPC "
                f"{st['mpc']['median_ms']:.3g}), MPC p99 {st['mpc']['p99_ms']:.3g} ms; run {r['run_time_s']:.1f} s",
            )
        )
    return rows


def _montecarlo(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    rows = []
    for m, r in d["methods"].items():
        rows.append(
            (
                f"Monte Carlo {m}, {name.removeprefix('montecarlo_')}, {d['runs']} runs, master seed {d.get('master_seed')}"
                f"{_plant(d)}",
                f"J_p {r['J_p']['mean']:.4g} (3 sigma {r['J_p']['3sigma']:.2g}), J_r {r['J_r']['mean']:.4g}; runs "
                f"outside the tube {r['runs_outside_tube']}/{d['runs']}; campaign {d['wall_time_s']:.0f} s",
            )
        )
    return rows


def _sweep(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    rows = []
    for label, r in d["rows"].items():
        rows.append(
            (
                f"lambda sweep {name.removeprefix('sweep_')}, seed {d['seed']}{_plant(d)}: {label}",
                f"J_p {r['J_p']:.4g}, J_r {r['J_r']:.4g}, mean x tube half-width {r['mean_tube_half_width_x_m']:.3g} m; "
                f"steps outside the tube {r['steps_outside_tube']}, failed LMI designs {r['tube_design_failures']}, "
                f"steps on the last certified tube {r['tube_uncertified_steps']}",
            )
        )
    return rows


def _per_flight(d: dict[str, Any], r: dict[str, Any]) -> str:
    """The pooled flights of a `--repeats` run and each flight's own ratio."""
    each = r.get("estimator_p99_ratio_per_flight", [])
    if d.get("repeats", 1) <= 1 or not each:
        return ""
    return f"; step times of {d['repeats']} flights pooled, each flight's ratio " + ", ".join(f"{x:.3g}x" for x in each)


def _controller(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    rows = []
    for m, r in d["methods"].items():
        c, cmd, t, i, p = r["controller"], r["command"], r["tube"], r["identify"], r["predict"]
        rows.append(
            (
                f"controller step {m}, {name.removeprefix('controller_')} (design worker {d['design_worker']})",
                f"median {c['median_ms']:.3g} ms, p99 {c['p99_ms']:.3g} ms, max {c['max_ms']:.3g} ms (to the command: "
                f"p99 {cmd['p99_ms']:.3g} ms, max {cmd['max_ms']:.3g} ms); identification median {i['median_ms']:.3g} "
                f"ms + tube update median {t['median_ms']:.3g} ms = {r['identify_tube_over_mpc_median']:.3f}x the MPC "
                f"step's median (tube max {t['max_ms']:.3g} ms); prediction median {p['median_ms']:.3g} ms; steps "
                f"outside the tube {r['steps_outside_tube']}, uncertified {r['uncertified_steps']}",
            )
        )
        if "estimator" in r:
            n, e, b = r["navigation"], r["estimator"], r["full_state_controller"]
            ce = r["controller_and_estimator"]
            rows.append(
                (
                    f"controller step {m} with the onboard estimator, {name.removeprefix('controller_')}",
                    f"estimator median {e['median_ms']:.3g} ms, p99 {e['p99_ms']:.3g} ms; controller + estimator p99 "
                    f"{ce['p99_ms']:.3g} ms = {r['estimator_p99_ratio']:.3g}x the full-state controller's p99 "
                    f"({b['p99_ms']:.3g} ms, the same scenario on the true state); the whole navigation call with the "
                    f"sensors' simulation median {n['median_ms']:.3g} ms, p99 {n['p99_ms']:.3g} ms "
                    f"({r['navigation_p99_ratio']:.3g}x)" + _per_flight(d, r),
                )
            )
    return rows


def _integrator(d: dict[str, Any]) -> list[tuple[str, str]]:
    rows = []
    for name, r in d["candidates"].items():
        o, f = r["one_step_max"], r["final"]
        rows.append(
            (
                f"truth integrator {name} over {d['intervals']} intervals of {d.get('scenario', 'bennu-paper')}, "
                f"against {d['reference']['method']}",
                f"one step <= {o['position_m']:.2g} m, {o['velocity_m_s']:.2g} m/s ({r['one_step_over_sigma']:.1e} of "
                f"the disturbance sigma); after the mission {f['position_m']:.2g} m; "
                f"{r['evaluations_per_interval']:.0f} evaluations"
                + (
                    f" ({r['field_evaluations_per_interval']:.2g} of the gravity field, largest expansion error found "
                    f"{r['largest_expansion_error']:.2g} m/s^2)"
                    if "field_evaluations_per_interval" in r
                    else ""
                )
                + f", {r['ms_per_interval']:.3g} ms per interval",
            )
        )
    return rows


def _runcost(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    c = d["campaign_run"]
    rows = [
        (
            f"one campaign run of {d['scenario']} ({', '.join(c['methods'])}; the campaign's run function after a "
            "warm-up run, set-up shared)",
            f"{c['core_s_per_run']['mean']:.3g} core-s per run (min {c['core_s_per_run']['min']:.3g}, "
            f"{c['runs']} runs), {c['wall_s_per_run']['mean']:.3g} s wall",
        )
    ]
    for method, r in d.get("cpp_run", {}).get("methods", {}).items():
        parts = ", ".join(
            f"{g.replace('_', ' ')} {r[g] / r['total']:.0%}"
            for g in ("truth_propagation", "polyhedral_gravity", "controller_steps", "controller_setup", "navigation")
        )
        rows.append(
            (
                f"instructions of the whole C++ run of {d['scenario']}, {method} (examples/cpp/closed_loop under "
                "callgrind, set-up included)",
                f"{r['total']:.3g} ({r['per_step']:.3g} per step); inclusive shares: {parts}",
            )
        )
    return rows


def _vec(v: list[float]) -> str:
    return "(" + ", ".join(f"{x:.3g}" for x in v) + ")"


def _actuators(d: dict[str, Any]) -> list[tuple[str, str]]:
    a, b, e = d["allocation"], d["achievable_box"], d["actuation_error"]
    where = f"{d['preset']} ({d['thrusters']} thrusters, {d['wheels']} wheels), {d['commands']} random commands"
    return [
        (
            f"thruster and wheel allocation per solve, {where}",
            f"median {a['solve_us']['median']:.3g} us, p99 {a['solve_us']['p99']:.3g} us; iterations median "
            f"{a['iterations']['median']:.0f}, max {a['iterations']['max']:.0f}; "
            + ", ".join(f"{k} {v}" for k, v in sorted(a["statuses"].items())),
        ),
        (
            "same problems through scipy's BVLS (lsq_linear)",
            f"median {a['scipy_bvls_us']['median']:.3g} us; allocation difference <= "
            f"{a['max_x_difference_over_bounds']:.1e} of the bounds, objective excess <= {a['max_objective_excess']:.1e}",
        ),
        (
            f"achievable wrench box (N, N m), {d['preset']}",
            f"half-widths healthy {_vec(b['healthy_half_width_B'])}, any one thruster failed "
            f"{_vec(b['one_failure_half_width_B'])}; {b['seconds']['one_failure']:.2g} s",
        ),
        (
            f"certified actuation-error box (N, N m), {d['preset']}, period {d['period_s']:g} s",
            f"{_vec(e['wrench_B'])} (modulation {_vec(e['modulation_B'])}); sampled errors reach "
            f"{_vec(e['worst_sampled_over_bound'])} of it",
        ),
        (
            f"same, for commands inside the achievable box, {d['preset']}",
            f"{_vec(e['in_box']['wrench_B'])} (thrust norm <= {e['in_box']['thrust_norm']:.3g} N, against "
            f"{e['in_box']['thrust_norm_any_command']:.3g} N for any command); sampled errors reach "
            f"{_vec(e['in_box']['worst_sampled_over_bound'])} of it; {e['in_box']['seconds']:.2g} s",
        ),
    ]


def _actuation(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    rows = []
    for m, r in d["methods"].items():
        a, b = r["actuators"], r["ideal"]
        rows.append(
            (
                f"{m} with {_file_name(d['actuators'])} against ideal actuators with the same bounds, "
                f"{name.removeprefix('actuation_')} (seed {d['seed']})",
                f"steps outside the tube {a['steps_outside_tube']} (ideal {b['steps_outside_tube']}); terminal "
                f"position error {1e3 * a['terminal_position_error_m']:.3g} mm = {r['terminal_error_ratio']:.3g}x "
                f"the ideal's; net delta-v {a['net_delta_v_m_s']:.4g} m/s = {r['net_delta_v_ratio']:.4g}x, thrusters' "
                f"{a['thruster_delta_v_m_s']:.4g} m/s, propellant {a['propellant_kg']:.3g} kg, {a['pulses']} pulses, "
                f"wheels <= {a['max_wheel_momentum_N_m_s']:.3g} N m s; controller p99 {a['controller_p99_ms']:.3g} ms, "
                f"with the actuation call {a['controller_and_actuation_p99_ms']:.3g} ms (+{r['p99_growth_ms']:.3g} ms)"
                f"{_over_seeds(r, b)}",
            )
        )
    return rows


def _over_seeds(r: dict[str, Any], ideal: dict[str, Any]) -> str:
    """The terminal-error ratio over the seeds `bench actuation --seeds` flew, and the ideal run's p99."""
    text = f"; the ideal run's controller p99 {ideal['controller_p99_ms']:.3g} ms"
    o = r.get("over_seeds")
    if o is None:
        return text
    n = len(o["terminal_error_ratio"])
    return (
        f"{text}; over {n} seeds the terminal-error ratio has median {o['terminal_error_ratio_median']:.3g}x "
        f"(at most {max(o['terminal_error_ratio']):.3g}x, within 2x in {round(o['share_within_2x'] * n)} of {n}), "
        f"the errors' median {o['median_error_ratio']:.3g}x and RMS {o['rms_error_ratio']:.3g}x the ideal runs'"
    )


def _navigation(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    p, v, t, n = d["touchdown_position_error_m"], d["touchdown_velocity_error_m_s"], d["output_feedback_tube"], d["nees"]
    where = f"{d['runs']} runs of {d['method']}, {name.removeprefix('navigation_')}"
    return [
        (
            f"touchdown on navigation, {where}",
            f"position error max {p['max']:.3g} m (p99.7 {p['p99_7']:.3g}), velocity error max {100 * v['max']:.3g} cm/s "
            f"(p99.7 {100 * v['p99_7']:.3g}); runs over 1 m / 2 cm/s: {p['runs_over_1_m']} / {v['runs_over_2_cm_s']}; "
            f"cone violations {d['runs_with_cone_violation']} runs; {d['run_time_s_mean']:.3g} s per run",
        ),
        (
            f"output-feedback tube and filter consistency, {where}",
            f"true state in z + Omega (+) E: largest gauge {t['max_gauge_true_state']:.3g}, runs outside "
            f"{t['runs_true_state_outside']}; average NEES over {n['runs']} runs {n['average_over_runs_and_steps']:.3g} "
            f"(95 % bounds {n['bounds_95'][0]:.3g}-{n['bounds_95'][1]:.3g}, {100 * n['steps_inside_bounds_fraction']:.0f} % "
            f"of steps inside); landmarks per frame {d['landmarks_per_frame']['mean']:.3g}",
        ),
    ]


def _campaign_time(d: dict[str, Any]) -> str:
    """A physics campaign's time: the runs' own (summed over the workers' runs: a resumed campaign's wall time is its
    last invocation's) where recorded, else the campaign's wall time."""
    if "runs_time_s" in d:
        return f"runs {d['runs_time_s']:.0f} s summed over the runs ({d.get('workers')} worker(s))"
    return f"campaign {d['campaign_wall_time_s']:.0f} s"


def _physics(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    """A campaign in the dispersed physical environment (tools/physics_campaign.py): per method the tube, J_p, J_r
    and the touchdown errors; then each of the paper's claims under physics, when measured."""
    where = f"{d['scenario']}, {d['runs']} runs, master seed {d.get('master_seed')}{_plant(d)}"
    rows = []
    for m, r in d["methods"].items():
        p, v, s, me = (
            r["touchdown_position_error_m"],
            r["touchdown_velocity_error_m_s"],
            r["steps_outside_tube"],
            r["drawn_mass_error"],
        )
        left = (
            f" (drawn mass errors {me['runs_outside_tube'][0]:.3g} to {me['runs_outside_tube'][1]:.3g})"
            if me["runs_outside_tube"]
            else ""
        )
        rows.append(
            (
                f"physical environment dispersed, {m}, {where}",
                f"runs outside the tube {r['runs_outside_tube']}/{r['runs']}{left}, steps outside {s['total']} (at most "
                f"{s['max_per_run']} in a run), largest excursion {r['max_tube_excursion']:.3g}; J_p {r['J_p']['mean']:.4g} "
                f"(3 sigma {r['J_p']['3sigma']:.2g}), J_r {r['J_r']['mean']:.4g} (3 sigma {r['J_r']['3sigma']:.2g}); "
                f"touchdown error max {1e3 * p['max']:.3g} mm (mean {1e3 * p['mean']:.3g}), {1e3 * v['max']:.3g} mm/s "
                f"(mean {1e3 * v['mean']:.3g}); runs inside the body {r['runs_inside_body']}, with cone violations "
                f"{r['runs_with_cone_violation']}; {_campaign_time(d)}",
            )
        )
    for c in d.get("claims", []):
        rows.append((f"the paper's claim under physics, {where}: {c['claim']}", f"{c['measured']}; holds: {c['holds']}"))
    return rows


def _test_command(d: dict[str, Any]) -> list[tuple[str, str]]:
    phases = d.get("phases_s")  # absent in files written before the phases were timed
    split = "" if not phases else "; " + ", ".join(f"{k} {v:.0f} s" for k, v in phases.items())
    return [
        (
            f"test command `{d['command']}`",
            f"{d['seconds'] / 60:.1f} min ({d['seconds']:.0f} s{split})",
        )
    ]


def _store(d: dict[str, Any]) -> list[tuple[str, str]]:
    """tubempc bench store: the campaign store's write and read times and bytes per run."""
    per_run = d["runs_bytes_per_run"] + d["steps_bytes_per_run"]
    return [
        (
            f"campaign store (Parquet), {d['runs']} runs made from one flown {d['scenario']} run "
            f"({', '.join(d['methods'])}: {d['runs_columns']} columns per run, {d['steps_rows'] // d['runs']} step rows)",
            f"write {1e3 * d['write_s_per_run']:.3g} ms/run (parts, merges and the final merge); read the runs "
            f"table {1e6 * d['read_runs_table_s_per_run']:.3g} us/run, every per-step array "
            f"{1e3 * d['read_steps_s_per_run']:.3g} ms/run, one run alone {1e3 * d['read_one_run_s']:.3g} ms; "
            f"{per_run / 1e3:.3g} kB/run ({d['runs_bytes_per_run']:.0f} B runs table, "
            f"{d['steps_bytes_per_run'] / 1e3:.3g} kB per-step arrays), {d['files']} files; 10^5 runs: "
            f"{per_run * 1e5 / 1e9:.2g} GB"
            + (f" (load average {d['load_average_1min']:.1f} during the run)" if "load_average_1min" in d else ""),
        )
    ]


def _faults(d: dict[str, Any], name: str) -> list[tuple[str, str]]:
    """A fault campaign (tools/fault_campaign.py): how the runs ended, the aborts' certification, and per fault kind
    the runs, the detections and their latency."""
    where = f"{d['runs']} runs of {d['method']}, {name.removeprefix('faults_')}"
    e, a = d["ends"], d["aborts"]
    spec = d["spec"]
    causes = ", ".join(f"{k} {v}" for k, v in a["causes"].items()) or "none"
    kinds = set(d["per_fault_kind"])
    what = "fault-free campaign with the abort armed" if kinds == {"none"} else "fault campaign, one fault per run"
    entered = "" if not a["runs"] else f"; entered at {a['entry_time_s']['median']:.0f} s median"
    rows = [
        (
            f"{what}, {where}",
            f"landed within {spec['position_m']:g} m and {100 * spec['velocity_m_s']:g} cm/s "
            f"{e.get('landed_within_spec', 0)}, aborted safe {e.get('aborted_safe', 0)}, landed outside the spec "
            f"{e.get('landed_outside_spec', 0)}, aborted not safe {e.get('aborted_unsafe', 0)}, failed runs "
            f"{d['failed_runs']}; aborts {a['runs']} (causes {causes}{entered}), lowest final height of an abort "
            f"{a['lowest_final_height_m'] if a['lowest_final_height_m'] is not None else float('nan'):.3g} m, abort "
            f"steps on an uncertified tube {a['steps_on_an_uncertified_tube']} "
            f"(largest LMI residual {a['max_lmi_residual'] if a['max_lmi_residual'] is not None else float('nan'):.2g}); "
            f"runs with steps outside the tube {d['runs_with_steps_outside_tube']}, inside the body "
            f"{d['runs_inside_body']}; {d['run_time_s_mean']:.3g} s per run",
        )
    ]
    for kind, k in d["per_fault_kind"].items():
        lat = k["latency_s"]
        latency = (
            "not detected" if lat["median"] is None else f"latency median {lat['median']:.3g} s, worst {lat['worst']:.3g} s"
        )
        rows.append(
            (
                f"fault campaign, {kind}, {where}",
                f"{k['runs']} runs: detected {k['detected']} ({latency}), aborted {k['aborted']} "
                f"(safe {k.get('aborted_safe', 0)}), landed in spec {k.get('landed_within_spec', 0)}, outside "
                f"{k.get('landed_outside_spec', 0)}; refused past the commit step {k['refused_past_commit']}",
            )
        )
    return rows


def _abort(d: dict[str, Any]) -> list[tuple[str, str]]:
    """tubempc bench abort: the controller step's p99 with and without the abort, and the supervision's call."""
    f = d["flights"]
    return [
        (
            f"safe abort's cost in the step ({d['method']}, seed {d['seed']}, commit step {d['commit_step']})",
            f"controller step p99 {f['without_abort']['p99_ms']:.3g} ms without the abort, {f['armed']['p99_ms']:.3g} ms "
            f"armed ({d['armed_p99_growth_ms']:+.3g} ms); commanded run: descent steps p99 "
            f"{f['commanded_descent_steps']['p99_ms']:.3g} ms, abort steps {f['commanded_abort_steps']['p99_ms']:.3g} ms "
            f"({d['abort_over_descent_p99']:.2f}x); SafeAbort.monitor {d['monitor_us_binding_included']:.2g} us per call "
            f"through the binding; library set-up {d['library_setup_s']:.3g} s",
        )
    ]


EXTRACTORS: dict[str, Callable[[dict[str, Any], str], list[tuple[str, str]]]] = {
    "gravity": lambda d, _: _gravity(d),
    "dynamics": lambda d, _: _dynamics(d),
    "mpc": lambda d, _: _mpc(d),
    "embed": lambda d, _: _embed(d),
    "fuzz": lambda d, _: _fuzz(d),
    "run": _run,
    "controller": _controller,
    "integrator": lambda d, _: _integrator(d),
    "montecarlo": _montecarlo,
    "sweep": _sweep,
    "test_command": lambda d, _: _test_command(d),
    "actuators": lambda d, _: _actuators(d),
    "actuation": _actuation,
    "navigation": _navigation,
    "plant": lambda d, _: _plant_bench(d),
    "store": lambda d, _: _store(d),
    "physics": _physics,
    "faults": _faults,
    "abort": lambda d, _: _abort(d),
    "runcost": _runcost,
}


MIPS = 200.0  # the reference processor of the instruction counts' column


def _instructions_rows(d: dict[str, Any]) -> list[str]:
    """The rows of the instruction-count table of one instructions_<scenario>.json (tubempc bench instructions):
    per method and component the median, p99 and max instructions per step, the same as ms on a 200 MIPS
    processor, and what the worst step did."""

    def ms(ir: float) -> str:
        return f"{ir / (MIPS * 1e6) * 1e3:.3g}"

    names = {
        "controller": "controller step",
        "navigation": "navigation call (with the sensors' simulation)",
        "estimator": "onboard estimator (navigation less the sensors)",
        "actuation": "actuation step",
    }
    rows = []
    for method, m in d["methods"].items():
        comps = [(names[c], v) for c, v in m["components"].items()]
        if len(m["onboard"]["parts"]) > 1:
            comps.append((" + ".join(m["onboard"]["parts"]) + " per period", m["onboard"]))
        for what, c in comps:
            w = c["worst"]
            if "scp_iterations" in w:
                did = (
                    f"k = {w['step']}: {w['scp_iterations']} SCP iteration(s), {w['active_set_solves']} active-set "
                    f"solve(s) with {w['active_set_iterations']} factorisations ({w['active_set_failures']} failed), "
                    f"{w['qp_iterations']} PIQP iterations, {w['model_evaluations']} nodes discretised, "
                    f"{w['gravity_evaluations']} gravity evaluations "
                    f"({100 * w['gravity_instructions'] / w['instructions']:.0f} % of the step), "
                    f"LDL^T {100 * w['ldlt_instructions'] / w['instructions']:.0f} %; over the mission "
                    f"gravity {100 * c['share_gravity']:.0f} %, LDL^T {100 * c['share_ldlt']:.0f} %"
                )
            elif "sensor_instructions" in w:
                did = (
                    f"k = {w['step']}: {w['measurements']} measurements folded in, {w['gravity_evaluations']} gravity "
                    f"evaluations, sensors' simulation {100 * w['sensor_instructions'] / w['instructions']:.0f} %"
                )
            elif "allocation_iterations" in w:
                did = f"k = {w['step']}: {w['allocation_iterations']} allocation iterations"
            else:
                did = f"k = {w['step']}"
            rows.append(
                f"| {d['scenario']} | {method} | {what} | {c['median']:.3g} | {c['p99']:.3g} | {c['max']:.3g} | "
                f"{ms(c['median'])} / {ms(c['p99'])} / {ms(c['max'])} | {did} |"
            )
        if "setup_instructions" in m:  # once per run, before the first step
            ir = m["setup_instructions"]
            rows.append(
                f"| {d['scenario']} | {method} | set-up, once per run | | | {ir:.3g} | {ms(ir)} | the controller's setup "
                "(the reference discretised for the whole mission), the abort's, the navigation's initialisation |"
            )
        if "abort" in m:  # the supervised descent's controller steps and the safe abort's, apart
            a = m["abort"]
            for what, c in (
                (f"controller step, supervised descent (k < {a['entered_at_step']})", a["descent_controller"]),
                (f"controller step, safe abort ({a['cause']}, k >= {a['entered_at_step']})", a["abort_controller"]),
            ):
                rows.append(
                    f"| {d['scenario']} | {method} | {what} | {c['median']:.3g} | {c['p99']:.3g} | {c['max']:.3g} | "
                    f"{ms(c['median'])} / {ms(c['p99'])} / {ms(c['max'])} | |"
                )
    return rows


def _instructions_section(files: list[tuple[str, dict[str, Any]]]) -> list[str]:
    if not files:
        return []
    lines = [
        "",
        "## Instructions per step",
        "",
        "Instructions counted by valgrind's callgrind in each call of the C++ example flying the exported",
        "scenario (`tubempc bench instructions`: the run's seed, disturbance, navigation and actuators; only the",
        "calls are counted); ms on a 200 MIPS processor = instructions / 200e6 (one instruction per cycle: an",
        "order of magnitude for a RAD750- or LEON4-class core). The same binary and input give the same counts;",
        "another machine's glibc may pick other variants of its string and math routines.",
        "",
        "| scenario | method | step | median | p99 | max | ms on a 200 MIPS processor (median / p99 / max) | "
        "the worst step |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for _, d in files:
        lines += _instructions_rows(d)
    memory = [(name, d) for name, d in files if d.get("setup_memory_bytes")]
    if memory:
        lines += [
            "",
            "Heap memory each component keeps after its set-up (kB, the blocks' usable sizes; peak in brackets;",
            "counted by the example's allocation counter in the native flight): the scenario file, the gravity models",
            "and ray casters shared by both methods, then per method the controller's construction and setup (the MPC's",
            "setup with its QP solvers' workspaces, the reference discretised for the tube update, the designs), the",
            "navigation and the actuation.",
            "",
            "| scenario | shared | tbmpc | ffa | the largest |",
            "| --- | --- | --- | --- | --- |",
        ]
        for _, d in memory:
            mem = d["setup_memory_bytes"]

            def kb(parts: dict[str, Any]) -> str:
                return ", ".join(
                    f"{k.replace('_', ' ')} {v['retained'] / 1e3:.4g} ({v['peak'] / 1e3:.4g})"
                    for k, v in parts.items()
                    if v is not None
                )

            big = mem["largest"]
            per = [kb(mem["methods"].get(m, {})) or "-" for m in ("tbmpc", "ffa")]
            lines.append(
                f"| {d['scenario']} | {kb(mem['shared'])} | {per[0]} | {per[1]} | {big['component'].replace('_', ' ')}: "
                f"{big['retained'] / 1e6:.3g} MB |"
            )
    lines.append("")
    lines.append("| file | runs, largest relative difference between them | command | machine, date, build |")
    lines.append("| --- | --- | --- | --- |")
    for name, d in files:
        m = d.get("machine", {})
        b = d.get("example_build", {})
        lines.append(
            f"| {name}.json | {d['runs']}, {d['max_relative_difference_between_runs']:.2g}; instrumented flights "
            f"{d['instrumented_wall_s']:.0f} s | `{portable_command(m.get('command', '?'), name, 'instructions', d)}` | "
            f"{m.get('cpu', '?')}, {m.get('cores', '?')} cores; {m.get('date', '?')}; {d['valgrind']}, "
            f"{b.get('compiler', '?')} {b.get('cxx_flags', '')} |"
        )
    return lines


SECTIONS = {"instructions": _instructions_section}


def _kind(name: str) -> str:
    for kind in [*EXTRACTORS, *SECTIONS]:
        if name == kind or name.startswith(kind + "_"):
            return kind
    raise SystemExit(f"{name}.json: no extractor for this benchmark (known: {', '.join([*EXTRACTORS, *SECTIONS])})")


def main() -> int:
    lines = [
        "# Benchmarks",
        "",
        "Current figures, generated by `python tools/benchmarks_md.py` from the JSON files in",
        "`docs/benchmarks/` (each written by the command in its row, run from the repository's root with the",
        'package installed; `101955bennu.tab` is the Bennu radar shape model: README, "Real Bennu shape',
        'model"). Timings on this machine drift by 20-50 % within a day: compare figures of one run with each',
        "other. History: `git log docs/benchmarks`.",
        "",
        "| what | figure | command | machine, date |",
        "| --- | --- | --- | --- |",
    ]
    sections: dict[str, list[tuple[str, dict[str, Any]]]] = {kind: [] for kind in SECTIONS}
    for path in sorted(DATA.glob("*.json")):
        d = json.loads(path.read_text(encoding="utf-8"))
        m = d.get("machine", {})
        where = f"{m.get('cpu', '?')}, {m.get('cores', '?')} cores; {m.get('date', '?')}"
        kind = _kind(path.stem)
        if kind in SECTIONS:
            sections[kind].append((path.stem, d))
            continue
        command = portable_command(d.get("command") or m.get("command", "?"), path.stem, kind, d)
        for what, figure in EXTRACTORS[kind](d, path.stem):
            lines.append(f"| {what} | {figure} | `{command}` | {where} |")
    for kind, files in sections.items():
        lines += SECTIONS[kind](files)
    out = ROOT / "docs" / "benchmarks.md"
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
