"""The certified safe abort (docs/model.md M52-M54; [abort], tubempc.design.abort, tubempc.sim.abort,
control/abort.hpp): the section's errors name the field; the hover reference holds the hover; the library's
certified entries end safe and bound the disturbance limit; a commanded abort leaves the descent untouched before
its entry, backs away to the hover on tubes certified at every step, and says so in the summary and the exit
status; a command past the commit step is refused and the descent lands; a disturbance burst enters the abort by
the estimate's exit, the inputs' innovation or the identified ratio, each recomputed from the record."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
import scipy.linalg

from tubempc.analysis import figures
from tubempc.analysis.runner import aborted, guarantee_lost, run_summary
from tubempc.analysis.view3d import mission_view_html
from tubempc.commands import EXIT_ABORTED, EXIT_GUARANTEE_LOST, EXIT_OK, guarantee_status
from tubempc.config import ConfigError, load_config
from tubempc.design.abort import abort_library, design_envelope, height_above_site, hover_reference
from tubempc.design.tube import tube_excursion
from tubempc.scenario import build_scenario
from tubempc.sim.closed_loop import simulate

#: A sparse library (every 25 steps) keeps the set-up short.
ABORT = {"abort.enabled": True, "abort.entry_period": 25}


@pytest.fixture(scope="module")
def tag(tmp_path_factory: pytest.TempPathFactory) -> Any:
    cfg = load_config(scenario="bennu-tag").with_overrides(ABORT)
    return build_scenario(cfg, cache_dir=tmp_path_factory.mktemp("cache"))


def _with(scn: Any, overrides: dict[str, Any]) -> Any:
    """The scenario with changed [abort] fields (the same reference; the library made again)."""
    out = dataclasses.replace(scn, config=scn.config.with_overrides(overrides))
    out.tube_designs.update({k: v for k, v in scn.tube_designs.items() if k != "abort"})
    return out


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"abort.safe_altitude": "60 m"}, "abort.safe_altitude"),
        ({"abort.command_time": "400 s"}, "abort.command_time"),
        ({"abort.entry_period": 0}, "abort.entry_period"),
        ({"abort.hover_altitude": "-5 m"}, "abort.hover_altitude"),
        ({"abort.disturbance_limit": 0.0}, "abort.disturbance_limit"),
    ],
)
def test_bad_fields_are_named(overrides: dict[str, Any], field: str) -> None:
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        load_config(scenario="bennu-tag").with_overrides({**ABORT, **overrides})


def test_an_abort_needs_a_site() -> None:
    with pytest.raises(ConfigError, match=r"abort\.enabled.*boundary\.terminal"):
        load_config().with_overrides({"abort.enabled": True})


def test_the_hover_reference_holds_the_hover_turning_with_the_body(tag: Any) -> None:
    hover = hover_reference(tag)
    height = height_above_site(tag, hover.x, hover.t)
    assert len(hover.t) == tag.n_steps + tag.config.mpc.horizon + 1  # one horizon past the mission's end
    np.testing.assert_array_equal(hover.t[: tag.n_steps + 1], tag.reference.t)
    np.testing.assert_allclose(height, tag.config.abort.hover_altitude, rtol=0, atol=1e-9)
    # at rest relative to the surface: the velocity in L is omega_AL x r_L
    w_AL_L = np.array([0.0, 0.0, tag.model.rotation_rate_AL])
    np.testing.assert_allclose(hover.x[:, 3:6], np.cross(w_AL_L, hover.x[:, :3]), rtol=0, atol=1e-12)
    assert hover.max_defect < 1e-3  # its input keeps the model on it (m, m/s, rad, rad/s)
    u_max, _ = tag.input_bounds
    assert np.abs(hover.u[:, :3]).max() < 1e-3 * u_max  # a hover near Bennu costs almost nothing


def test_the_library_certifies_its_entries_up_to_the_commit_step(tag: Any) -> None:
    lib = abort_library(tag)
    assert lib is abort_library(tag)  # once per scenario
    steps = [e.step for e in lib.entries]
    assert steps == list(range(0, tag.n_steps, 25))
    assert lib.commit_step in steps
    safe = tag.config.abort.safe_altitude
    for e in lib.entries:
        if e.step > lib.commit_step:
            break
        assert e.certified and e.reason == ""
        assert e.max_residual <= 0.0 and e.max_glide_slope_m <= 0.0
        assert e.final_height_m >= safe and e.lowest_height_m > 0.0
        assert e.plan.shape == (tag.n_steps - e.step + 1, 12)
    # an entry is not certified when its plan cannot end safe: a safe altitude it cannot reach in the time left
    strict = abort_library(_with(tag, {"abort.safe_altitude": "49.999 m", "abort.hover_altitude": "50 m"}))
    late = [e for e in strict.entries if not e.certified]
    assert all("below abort.safe_altitude" in e.reason for e in late)
    assert strict.commit_step <= lib.commit_step


@pytest.fixture(scope="module")
def late(tag: Any) -> tuple[Any, Any]:
    """A run commanded to abort one step past the commit step: refused, the descent flown to the end."""
    t_late = (abort_library(tag).commit_step + 1) * tag.config.mpc.dt
    scn = _with(tag, {"abort.command_time": f"{t_late} s"})
    return scn, simulate(scn, "ffa", 0, design_worker="none")


@pytest.fixture(scope="module")
def commanded(tag: Any) -> tuple[Any, Any]:
    """A run commanded to abort at 100 s (step 50)."""
    scn = _with(tag, {"abort.command_time": "100 s"})
    return scn, simulate(scn, "ffa", 0, design_worker="none")


def test_a_commanded_abort_backs_away_certified_and_the_descent_before_it_is_unchanged(
    commanded: tuple[Any, Any], late: tuple[Any, Any]
) -> None:
    scn, rec = commanded
    entry = 50
    descent = late[1]
    np.testing.assert_array_equal(rec.x[: entry + 1], descent.x[: entry + 1])  # the descent flown to the entry
    assert not np.array_equal(rec.x[entry + 1], descent.x[entry + 1])
    s = run_summary(scn, rec)
    a = s.abort
    assert a is not None and a.outcome == "aborted" and a.cause == "command" and a.entered_at == 100.0
    assert a.safe and a.states_inside_body == 0 and a.max_glide_slope_g is not None and a.max_glide_slope_g <= 0.0
    assert a.abort_steps == scn.n_steps - entry
    assert a.uncertified_steps == 0 and a.max_residual is not None and a.max_residual <= 0.0
    assert a.final_height == pytest.approx(scn.config.abort.hover_altitude, abs=1.0)
    assert not guarantee_lost(s) and aborted(s) == "command at 100 s"
    assert type(s).from_json(s.to_json()) == s  # the summary round-trips
    assert guarantee_status({}, {"ffa": aborted(s) or ""}) == EXIT_ABORTED
    assert guarantee_status({"ffa": ["1 steps outside the tube"]}, {"ffa": "command at 100 s"}) == EXIT_GUARANTEE_LOST
    assert guarantee_status({}, {}) == EXIT_OK


def test_the_envelope_is_the_largest_prior_shaped_set_the_designs_cover_and_bounds_the_limit(tag: Any) -> None:
    lib = abort_library(tag)
    for i, (library, ident) in enumerate(
        (
            (lib.designs.library_p, lib.controller_settings.identification_p),
            (lib.designs.library_r, lib.controller_settings.identification_r),
        )
    ):
        prior = ident.pw_scale * np.asarray(ident.S0)
        # c P_W0 lies inside the largest design (all its generalised eigenvalues <= 1), a little more does not
        largest = max(library, key=lambda d: 1.0 / float(np.max(np.linalg.eigvals(np.linalg.solve(d.P_W, prior)).real)))
        inside = np.linalg.eigvals(np.linalg.solve(largest.P_W, lib.envelope[i] * prior)).real
        assert inside.max() == pytest.approx(1.0, rel=1e-9)
        assert lib.envelope[i] > tag.config.abort.disturbance_limit
    assert design_envelope(lib.designs, lib.controller_settings) == lib.envelope
    with pytest.raises(ValueError, match=r"abort\.disturbance_limit: 100 is beyond what the abort's designs certify"):
        abort_library(_with(tag, {"abort.disturbance_limit": 100.0}))


@pytest.fixture(scope="module")
def burst(tag: Any) -> tuple[Any, Any]:
    """A disturbance burst of 2x from 60 s (4x the prior's set)."""
    scn = _with(
        tag,
        {
            "faults.kind": "disturbance_burst",
            "faults.start": "60 s",
            "faults.burst_scale": 2.0,
            "abort.disturbance_limit": 3.0,
        },
    )
    return scn, simulate(scn, "ffa", 0, design_worker="none")


def test_a_burst_takes_the_state_out_of_its_tube_and_the_abort_backs_away_certified(burst: tuple[Any, Any]) -> None:
    scn, rec = burst
    # the excursion the C++ step reports (Controller::excursion) is the tube's quadratic form, solved here again
    z1 = rec.z_plan[:, 1]
    oracle = np.column_stack(
        [tube_excursion(rec.x[1:, sx], z1[:, sx], Pe) for sx, Pe in ((slice(0, 6), rec.Pe_p), (slice(6, 12), rec.Pe_r))]
    )
    np.testing.assert_allclose(rec.excursion, oracle, rtol=1e-9, atol=1e-12)
    a = run_summary(scn, rec).abort
    assert a is not None and a.cause == "estimate_outside_tube"
    k = round(a.entered_at / scn.config.mpc.dt)
    # entered at the step after the first exit, which is the burst's
    first_exit = int(np.argmax(np.any(rec.excursion > 1.0 + 1e-9, axis=1)))
    assert k == first_exit + 1 and 30 <= first_exit
    assert a.safe and a.uncertified_steps == 0 and a.max_residual is not None and a.max_residual <= 0.0


def test_the_measured_inputs_innovation_over_a_window_enters_the_abort(burst: tuple[Any, Any]) -> None:
    """The same burst with the excursion trigger off: the window's mean of the inputs' innovation (recomputed here
    from the record's inputs and identification) crosses the limit first at the entry."""
    scn = _with(burst[0], {"abort.on_estimate_outside_tube": False})
    rec = simulate(scn, "ffa", 0, design_worker="none")
    a = run_summary(scn, rec).abort
    assert a is not None and a.cause == "input_nis" and a.safe and a.uncertified_steps == 0
    m = round(a.entered_at / scn.config.mpc.dt)
    ident = abort_library(scn).controller_settings.identification_r
    window, limit = scn.config.abort.input_nis_window, scn.config.abort.input_nis_limit
    # step j folds in w_j-1 against the identification after w_j-2 (the prior for j = 1)
    nis = np.zeros(m)
    for j in range(1, m):
        mean, S = (np.asarray(ident.w0), np.asarray(ident.S0)) if j == 1 else (rec.w_hat[j - 2, 6:], rec.S_r[j - 2])
        d = rec.w[j - 1, 6:] - mean
        nis[j] = d @ np.linalg.solve(S, d) / 6.0
    # the monitor at step i sees step i - 1's value: its window is steps i - window .. i - 1
    means = np.array([nis[max(0, i - window) : i].sum() / window for i in range(1, m + 1)])
    assert means[-1] > limit and np.all(means[:-1] <= limit) and m > 30


def test_an_identified_set_beyond_the_limit_enters_the_abort(tag: Any, burst: tuple[Any, Any]) -> None:
    """The same burst with the excursion and innovation triggers off: the identification's ratio to the prior
    crosses the limit."""
    scn = _with(burst[0], {"abort.on_estimate_outside_tube": False, "abort.on_input_nis": False})
    rec = simulate(scn, "ffa", 0, design_worker="none")
    a = run_summary(scn, rec).abort
    assert a is not None and a.cause == "disturbance_beyond_limit"
    assert a.safe and a.uncertified_steps == 0
    k = round(a.entered_at / scn.config.mpc.dt)
    # the ratio of the identified covariance to the prior's, by a general eigen-solver: beyond the limit at the step
    # before the entry, within it at every step before (the set step j flies, rec.S_r[j - 1], folds in w_j-1)
    S0 = np.asarray(abort_library(scn).controller_settings.identification_r.S0)
    ratio = np.array([scipy.linalg.eigh(S, S0, eigvals_only=True).max() for S in rec.S_r[: k - 1]])
    assert ratio[-1] > 3.0 and np.all(ratio[:-1] <= 3.0) and k > 30


def test_a_command_past_the_commit_step_is_refused_and_the_descent_lands(tag: Any, late: tuple[Any, Any]) -> None:
    scn, rec = late
    s = run_summary(scn, rec)
    a = s.abort
    t_late = scn.config.abort.command_time
    assert a is not None and a.outcome == "landed" and a.cause == "none"
    assert a.refused_cause == "command" and a.refused_at == t_late
    assert a.commit_time == abort_library(tag).commit_step * scn.config.mpc.dt
    assert a.final_height < 5.0 and aborted(s) is None


def test_the_abort_is_marked_on_the_trajectory_the_timeline_and_the_3d_view(commanded: tuple[Any, Any]) -> None:
    scn, rec = commanded
    assert figures.fault_events(rec) == {"abort entered": 50}
    fig = figures.trajectory_3d({"ffa": rec}, scn.config.constraints.glide_slope_angle)
    labels = [h.get_label() for h in fig.axes[0].collections]
    assert "ffa: abort entered (100 s)" in labels
    heights = {"ffa": height_above_site(scn, rec.x, rec.t)}
    timeline = figures.fault_timeline({"ffa": rec}, heights, 145 * scn.config.mpc.dt)
    legend = timeline.axes[0].get_legend()
    assert legend is not None and any("abort entered" in t.get_text() for t in legend.get_texts())
    assert "TBMPC-FFA: abort entered (100 s)" in mission_view_html(scn, {"ffa": rec}, footprints=0)


def test_a_kept_abort_flies_the_bits_of_a_new_one(commanded: tuple[Any, Any]) -> None:
    """simulate keeps the safe abort in the scenario between runs, as the controller (SafeAbort.reset per run): the
    commanded abort flown again after another run that aborted on the same scenario equals its first flight."""
    scn, first = commanded
    other = simulate(scn, "ffa", 1, design_worker="none", max_steps=60)  # enters the abort at step 50 too
    assert other.applied["abort"]["entered_at_step"] == 50
    assert len(scn.controllers["abort"]) == 1
    again = simulate(scn, "ffa", 0, design_worker="none")
    for name in ("x", "u", "z", "K", "Pe_p", "Pe_r"):
        np.testing.assert_array_equal(getattr(again, name), getattr(first, name), err_msg=name)
    assert again.applied["abort"] == first.applied["abort"]
