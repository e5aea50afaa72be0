"""A campaign's statistics for a review board: Clopper-Pearson bounds against known values and the binomial
they invert, order-statistic intervals against their coverage, failure kinds counted from a runs table made
by hand, worst runs and the dispersion that drives a metric."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from scipy import stats

from tubempc.analysis.statistics import (
    campaign_statistics,
    clopper_pearson_upper,
    describe_bound,
    percentile_interval,
    touchdown_reason,
)


@pytest.mark.parametrize("n", [1, 10, 59, 100, 1000, 3000, 100_000])
def test_no_failure_in_n_runs_bounds_the_probability_by_1_minus_alpha_to_the_1_over_n(n: int) -> None:
    assert clopper_pearson_upper(0, n, 0.95) == pytest.approx(1.0 - 0.05 ** (1.0 / n), rel=1e-12)
    assert clopper_pearson_upper(0, n, 0.99) == pytest.approx(1.0 - 0.01 ** (1.0 / n), rel=1e-12)
    if n >= 100:  # the rule of three
        assert clopper_pearson_upper(0, n) == pytest.approx(3.0 / n, rel=0.02)


def test_clopper_pearson_matches_the_published_table_and_inverts_the_binomial() -> None:
    # Clopper and Pearson (1934), 95 % two-sided limits for 1 of 10: upper 0.4450 (its one-sided 97.5 %);
    # the one-sided 95 % upper limit of 1 of 10 is 0.3942 (e.g. Hahn & Meeker, Statistical Intervals, table)
    assert clopper_pearson_upper(1, 10, 0.975) == pytest.approx(0.4450, abs=5e-5)
    assert clopper_pearson_upper(1, 10, 0.95) == pytest.approx(0.3942, abs=5e-5)
    assert clopper_pearson_upper(5, 5) == 1.0
    for k, n, conf in [(0, 20, 0.95), (3, 1000, 0.95), (17, 250, 0.9), (40, 41, 0.99)]:
        p = clopper_pearson_upper(k, n, conf)
        assert stats.binom.cdf(k, n, p) == pytest.approx(1.0 - conf, rel=1e-9)  # P(X <= k | p_upper) = alpha
        assert p > k / n
    for bad in [(-1, 5, 0.95), (6, 5, 0.95), (0, 0, 0.95), (0, 5, 1.0)]:
        with pytest.raises(ValueError):
            clopper_pearson_upper(*bad)


def test_order_statistic_intervals_cover_the_percentile_at_their_confidence() -> None:
    n, conf = 60, 0.95
    for q in (50.0, 90.0):
        est = percentile_interval(np.arange(1.0, n + 1), q, conf)
        assert est.coverage is not None and est.coverage >= conf and est.lower is not None and est.upper is not None
        lo, hi = int(est.lower), int(est.upper)  # the sample 1..n: the value is the order statistic's rank
        p = q / 100.0
        assert est.coverage == pytest.approx(stats.binom.cdf(hi - 1, n, p) - stats.binom.cdf(lo - 1, n, p))
        assert stats.binom.cdf(lo - 1, n, p) <= (1 - conf) / 2 and stats.binom.cdf(hi - 1, n, p) >= 1 - (1 - conf) / 2
    # too few runs for an end: None, not a number
    est = percentile_interval(np.arange(10.0), 99.0, 0.95)
    assert est.upper is None and est.coverage is None and est.value == pytest.approx(8.91)
    # the intervals cover the true quantile of a continuous distribution at least 95 % of the time
    rng = np.random.default_rng(3)
    hits = 0
    trials = 2000
    true_q90 = stats.expon.ppf(0.9)
    for _ in range(trials):
        e = percentile_interval(rng.exponential(size=n), 90.0, conf)
        hits += bool(e.lower is not None and e.upper is not None and e.lower <= true_q90 <= e.upper)
    assert hits / trials >= conf - 3 * np.sqrt(conf * (1 - conf) / trials)


def _runs(n: int, *, seed: int = 0, inside: bool = True) -> pa.Table:
    """A runs table as the store holds it, with known failures: run 3 leaves the tube, run 5 violates the
    cone, run 7 lands 1.5 m off, run 8 failed; J_p grows with applied.scale (and nothing else)."""
    rng = np.random.default_rng(seed)
    scale = rng.uniform(0.9, 1.1, n)
    noise = rng.uniform(size=n)
    ok = np.arange(n) != 8
    jp = 10.0 * scale + 0.01 * rng.normal(size=n)
    exc = np.where(np.arange(n) == 3, 1.2, 0.5)
    cone = (np.arange(n) == 5).astype(int)
    pos = np.where(np.arange(n) == 7, 1.5, 0.05)

    def masked(v: np.ndarray) -> pa.Array:
        return pa.array(v, mask=~ok)

    cols = {
        "index": pa.array(np.arange(n)),
        "seed": pa.array(1000 + np.arange(n)),
        "status": pa.array(np.where(ok, "ok", "failed")),
        "ffa.J_p": masked(jp),
        "ffa.J_r": masked(np.ones(n)),
        "ffa.max_tube_excursion.translation": masked(exc),
        "ffa.max_tube_excursion.rotation": masked(np.full(n, 0.1)),
        "ffa.constraint_violations.glide_slope_steps": masked(cone),
        "ffa.constraint_violations.los_steps": masked(np.zeros(n, dtype=int)),
        "ffa.terminal_error.position": masked(pos),
        "ffa.terminal_error.velocity": masked(np.full(n, 0.01)),
        "applied.scale": pa.array(scale),
        "applied.noise": pa.array(noise),
        "applied.seed": pa.array(np.arange(n) * 7),  # an identifier: never a driver
        "applied.constant": pa.array(np.ones(n)),
        # a random stream's key (an identifier, beyond 2^53: never a driver) and an integer beyond 2^53 that does
        # not vary (read as a double: no failed cast)
        "applied.drawn.stream[0]": pa.array(2**62 + 7 * np.arange(n, dtype=np.int64)),
        "applied.big_constant": pa.array(np.full(n, 2**62 + 1, dtype=np.int64)),
    }
    if inside:
        cols["ffa.states_inside_body"] = masked(np.zeros(n, dtype=int))
    return pa.table(cols)


def test_failure_kinds_are_counted_and_bounded_and_a_kind_that_cannot_be_judged_says_so() -> None:
    n = 40
    st = campaign_statistics(_runs(n), ["ffa"], confidence=0.95, worst=3, drivers=2)
    f = st.methods["ffa"].failures
    done = n - 1
    assert (f["tube_exit"].failures, f["tube_exit"].runs) == (1, done)
    assert f["tube_exit"].upper_bound == pytest.approx(clopper_pearson_upper(1, done, 0.95))
    assert f["cone_violation"].failures == 1 and f["inside_body"].failures == 0
    assert f["inside_body"].upper_bound == pytest.approx(1 - 0.05 ** (1 / done))
    assert f["touchdown"].failures == 1  # touchdown=None: the runs landed
    assert f["any"].failures == 4 and f["any"].runs == n  # runs 3, 5, 7 and the failed run 8
    assert st.failed_run.failures == 1 and st.failed_run.runs == n
    # no touchdown, no count of states inside the body: not evaluated, with the reason, never 0
    reason = touchdown_reason("paper", 0.0, 300, None)
    assert reason is not None and "without a touchdown" in reason
    st2 = campaign_statistics(_runs(n, inside=False), ["ffa"], touchdown=reason)
    f2 = st2.methods["ffa"].failures
    assert (
        not f2["touchdown"].evaluated
        and f2["touchdown"].failures is None
        and "without a touchdown" in str(f2["touchdown"].reason)
    )
    assert not f2["inside_body"].evaluated and "not count" in str(f2["inside_body"].reason)
    assert f2["any"].failures == 3 and "touchdown" not in str(f2["any"].reason)
    assert describe_bound(f2["touchdown"], 0.95).startswith("not evaluated")
    assert describe_bound(f["tube_exit"], 0.95).startswith("1 of 39 runs, < ")
    assert touchdown_reason("site", 0.1, 150, 10) == "the runs were cut after 10 of 150 steps, before touchdown"
    assert touchdown_reason("site", 0.1, 150, None) is None


def test_worst_runs_carry_their_seeds_and_the_driver_is_the_dispersion_that_moves_the_metric() -> None:
    table = _runs(200, seed=4)
    st = campaign_statistics(table, ["ffa"], worst=3, drivers=2)
    jp = st.methods["ffa"].metrics["J_p"]
    values = np.array(table.column("ffa.J_p").to_pylist(), dtype=float)
    order = np.argsort(-np.nan_to_num(values, nan=-np.inf))[:3]
    assert [w.index for w in jp.worst] == order.tolist()
    assert [w.seed for w in jp.worst] == (1000 + order).tolist() and jp.worst[0].value == np.nanmax(values)
    top = jp.drivers[0]
    assert top.dispersion == "applied.scale" and top.rho > 0.99 and top.significant and top.p_value < 1e-10
    assert all(
        d.dispersion not in ("applied.seed", "applied.constant", "applied.drawn.stream[0]", "applied.big_constant")
        for d in jp.drivers
    )
    assert st.dispersions_varied == 2  # scale and noise
    assert len(jp.drivers) == 2 and not jp.drivers[1].significant  # noise: no correlation at 200 runs
    # a constant metric has no driver, and says why
    assert st.methods["ffa"].metrics["J_r"].drivers == [] and "same in every run" in str(
        st.methods["ffa"].metrics["J_r"].drivers_note
    )
    few = campaign_statistics(_runs(6), ["ffa"])
    assert few.methods["ffa"].metrics["J_p"].drivers == [] and "too few" in str(
        few.methods["ffa"].metrics["J_p"].drivers_note
    )


def test_an_abort_is_judged_by_its_safety_not_by_its_touchdown() -> None:
    n = 40
    table = _runs(n)
    assert not campaign_statistics(table, ["ffa"]).methods["ffa"].failures["abort_unsafe"].evaluated
    late = 7  # the run that lands 1.5 m off (_runs) now aborted, safe; run 0 aborted, not safe
    outcome = np.where(np.isin(np.arange(n), [0, late]), "aborted", "landed")
    safe = np.where(np.arange(n) == late, True, False)
    safe_col = pa.array([bool(s) if o == "aborted" else None for s, o in zip(safe, outcome, strict=True)], type=pa.bool_())
    aborted = table.append_column("ffa.abort.outcome", pa.array(outcome)).append_column("ffa.abort.safe", safe_col)
    f = campaign_statistics(aborted, ["ffa"]).methods["ffa"].failures
    assert f["touchdown"].failures == 0  # the missed touchdown was an abort
    assert f["abort_unsafe"].evaluated and f["abort_unsafe"].failures == 1
