"""What a review board asks of a campaign (docs/decisions.md "Failure bounds"): an upper confidence bound
on the probability of each failure kind (Clopper-Pearson), percentiles with distribution-free confidence
intervals (order statistics), the worst runs by each metric with their seeds, and the dispersions that
drive each metric (Spearman's rank correlation), from the campaign's store
(:mod:`tubempc.results.campaign_store`).

Failure kinds, per method over the runs that completed (:data:`FAILURE_KINDS`):

- ``tube_exit``: the largest tube excursion e^T Pe^-1 e above 1 in either subsystem at some step;
- ``touchdown``: the terminal error above :data:`tubempc.analysis.claims.TOUCHDOWN_GOAL` (1 m or 2 cm/s),
  evaluated only where the mission ends in a touchdown (``boundary.terminal = "site"`` with
  ``boundary.touchdown_speed`` > 0) and the runs flew to t_f;
- ``cone_violation``: a step of the actual trajectory violating the glide slope or the line of sight;
- ``inside_body``: a state inside the body (evaluated where the runs counted them);
- ``abort_unsafe``: with ``[abort]``, a run that aborted and did not end safe (above ``abort.safe_altitude``, inside
  the cone, never inside the body); a run that aborted safe is not judged by ``touchdown`` (it did not land);
- ``any``: any of the kinds evaluated, or a failed run, over every run attempted;

and, for the campaign, ``failed_run``: a run that raised instead of finishing. A kind that cannot be
evaluated says why instead of a number.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc
from scipy import stats

from ..results.summaries import (
    CampaignStatistics,
    Driver,
    FailureBound,
    MethodStatistics,
    MetricStatistics,
    PercentileEstimate,
    WorstRun,
)
from .claims import TOUCHDOWN_GOAL

__all__ = [
    "DEFAULT_PERCENTILES",
    "FAILURE_KINDS",
    "METRICS",
    "MIN_RUNS_DRIVERS",
    "campaign_statistics",
    "clopper_pearson_upper",
    "describe_bound",
    "failure_bound",
    "percentile_interval",
    "touchdown_reason",
]

Array = npt.NDArray[np.float64]

#: The failure kinds per method, in the order they are reported (the module docstring).
FAILURE_KINDS = ("tube_exit", "touchdown", "cone_violation", "inside_body", "abort_unsafe", "any")
#: Fewest runs whose rank correlations (and their p-values, from Student's t) the summary reports.
MIN_RUNS_DRIVERS = 10
#: Percentiles (%) the summary gives with their confidence intervals by default.
DEFAULT_PERCENTILES = (50.0, 90.0, 99.0)


def clopper_pearson_upper(failures: int, runs: int, confidence: float = 0.95) -> float:
    """The one-sided Clopper-Pearson upper bound at ``confidence`` on a probability of which ``failures``
    of ``runs`` independent trials occurred: the p with P(X <= failures | runs, p) = 1 - confidence, the
    ``confidence`` quantile of Beta(failures + 1, runs - failures); 1 when every run failed. With no
    failure it is 1 - (1 - confidence)^(1/runs) (about 3/runs at 95 %)."""
    if runs < 1 or not 0 <= failures <= runs:
        raise ValueError(f"Clopper-Pearson bound: need 0 <= failures <= runs and runs >= 1, got {failures} of {runs}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    if failures == runs:
        return 1.0
    return float(stats.beta.ppf(confidence, failures + 1, runs - failures))


def failure_bound(failures: int, runs: int, confidence: float) -> FailureBound:
    """A failure kind's count, rate and Clopper-Pearson upper bound."""
    return FailureBound(
        evaluated=True,
        failures=failures,
        runs=runs,
        rate=failures / runs,
        upper_bound=clopper_pearson_upper(failures, runs, confidence),
    )


def _not_evaluated(reason: str) -> FailureBound:
    return FailureBound(evaluated=False, reason=reason)


def percentile_interval(values: Array, percent: float, confidence: float) -> PercentileEstimate:
    """The ``percent`` percentile of ``values`` (linear interpolation) and its distribution-free two-sided
    confidence interval [x_(l), x_(u)] of order statistics (1-based): l = the binomial(n, p) quantile
    of (1 - confidence) / 2 and u = its (1 + confidence) / 2 quantile + 1, whose coverage
    F(u - 1) - F(l - 1) (F the binomial(n, p) distribution function; exact for a continuous metric, at
    least that for any) is at least ``confidence``. An end that would need an order statistic beyond
    the sample (too few runs) is None."""
    x = np.sort(np.asarray(values, dtype=float))
    n = len(x)
    if n == 0:
        raise ValueError("percentile of no runs")
    p = percent / 100.0
    if not 0.0 < p < 1.0:
        raise ValueError(f"percentile must lie in (0, 100), got {percent}")
    alpha = 1.0 - confidence
    lo = int(stats.binom.ppf(alpha / 2, n, p))
    hi = int(stats.binom.ppf(1 - alpha / 2, n, p)) + 1
    cdf_hi = 1.0 if hi > n else float(stats.binom.cdf(hi - 1, n, p))
    cdf_lo = 0.0 if lo < 1 else float(stats.binom.cdf(lo - 1, n, p))
    return PercentileEstimate(
        percent=percent,
        value=float(np.quantile(x, p)),
        lower=float(x[lo - 1]) if lo >= 1 else None,
        upper=float(x[hi - 1]) if hi <= n else None,
        coverage=cdf_hi - cdf_lo if lo >= 1 and hi <= n else None,
    )


def touchdown_reason(terminal: str, touchdown_speed: float, n_steps: int, max_steps: int | None) -> str | None:
    """Why a campaign's runs have no touchdown to judge (None: they have): a mission that does not end on
    the surface, or runs cut before t_f."""
    if terminal != "site" or touchdown_speed <= 0.0:
        return (
            f'the mission ends without a touchdown (boundary.terminal = "{terminal}", touchdown_speed '
            f"{touchdown_speed:g} m/s)"
        )
    if max_steps is not None and max_steps < n_steps:
        return f"the runs were cut after {max_steps} of {n_steps} steps, before touchdown"
    return None


# --- the metrics --------------------------------------------------------------------------------------


def _col(table: pa.Table, name: str) -> Array | None:
    """A numeric column as float (null: NaN); None when the table has no such column."""
    if name not in table.column_names:
        return None
    c = table.column(name)
    if pa.types.is_null(c.type):
        return np.full(table.num_rows, np.nan)
    # safe=False: integers beyond 2^53 (a seed) round to the nearest double instead of failing the cast
    return np.asarray(c.cast(pa.float64(), safe=False).to_numpy(zero_copy_only=False), dtype=float)


def _max(*cols: Array | None) -> Array | None:
    if any(c is None for c in cols):
        return None
    out: Array = np.maximum.reduce([c for c in cols if c is not None])
    return out


def _sum(*cols: Array | None) -> Array | None:
    if any(c is None for c in cols):
        return None
    out: Array = np.add.reduce([c for c in cols if c is not None])
    return out


Metric = Callable[[pa.Table, str], "Array | None"]

#: The metrics the summary gives percentiles, worst runs and drivers of (per method; higher is worse):
#: name -> (what it is, unit, how it is read from the runs table).
METRICS: dict[str, tuple[str, str, Metric]] = {
    "J_p": ("J_p", "", lambda t, m: _col(t, f"{m}.J_p")),
    "J_r": ("J_r", "", lambda t, m: _col(t, f"{m}.J_r")),
    "terminal_position_error": (
        "terminal position error",
        "m",
        lambda t, m: _col(t, f"{m}.terminal_error.position"),
    ),
    "terminal_velocity_error": (
        "terminal velocity error",
        "m/s",
        lambda t, m: _col(t, f"{m}.terminal_error.velocity"),
    ),
    "max_tube_excursion": (
        "largest tube excursion",
        "",
        lambda t, m: _max(_col(t, f"{m}.max_tube_excursion.translation"), _col(t, f"{m}.max_tube_excursion.rotation")),
    ),
    "max_cone_g": (
        "largest cone constraint value (> 0: violated)",
        "m",
        lambda t, m: _max(
            _col(t, f"{m}.constraint_violations.max_glide_slope_g_m"), _col(t, f"{m}.constraint_violations.max_los_g_m")
        ),
    ),
    "delta_v": ("delta-v", "m/s", lambda t, m: _col(t, f"{m}.control_effort.delta_v")),
    "nav_touchdown_estimation_error": (
        "estimation error at the last step",
        "m",
        lambda t, m: _col(t, f"{m}.navigation.touchdown_error.position"),
    ),
    "propellant": ("propellant", "kg", lambda t, m: _col(t, f"{m}.actuation.propellant")),
}


def _dispersions(table: pa.Table) -> tuple[list[str], Array]:
    """The applied dispersions that vary over the runs: the numeric ``applied.*`` columns with more than
    one value and no null, but the seeds (an identifier, not a dispersion)."""
    names, cols = [], []
    for name in table.column_names:
        if not name.startswith("applied.") or name.rsplit(".", 1)[-1].split("[")[0] in ("seed", "stream", "max_steps"):
            continue
        t = table.column(name).type
        if not (pa.types.is_integer(t) or pa.types.is_floating(t) or pa.types.is_boolean(t)):
            continue
        c = _col(table, name)
        if c is None or not np.all(np.isfinite(c)) or np.ptp(c) == 0.0:
            continue
        names.append(name)
        cols.append(c)
    return names, (np.column_stack(cols) if cols else np.zeros((table.num_rows, 0)))


def _drivers(y: Array, names: list[str], D: Array, top: int, confidence: float) -> tuple[list[Driver], str | None]:
    n = len(y)
    if not names:
        return [], "no applied dispersion varies over the runs"
    if n < MIN_RUNS_DRIVERS:
        return [], f"{n} runs: fewer than {MIN_RUNS_DRIVERS}, too few for rank correlations and their p-values"
    if np.ptp(y) == 0.0:
        return [], "the metric is the same in every run"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a perfect correlation divides by zero in the t statistic
        res = stats.spearmanr(np.column_stack([y, D]))
    rho_m = np.atleast_2d(np.asarray(res.statistic, dtype=float))
    p_m = np.atleast_2d(np.asarray(res.pvalue, dtype=float))
    rho, p = rho_m[0, 1:], p_m[0, 1:]
    order = sorted(range(len(names)), key=lambda j: (-abs(rho[j]) if np.isfinite(rho[j]) else 0.0, names[j]))
    alpha = 1.0 - confidence
    out = [
        Driver(
            dispersion=names[j],
            rho=float(rho[j]),
            p_value=float(p[j]),
            significant=bool(p[j] < alpha / len(names)),
        )
        for j in order[:top]
        if np.isfinite(rho[j])
    ]
    return out, None


def _worst(y: Array, index: Array, seed: list[int], count: int) -> list[WorstRun]:
    ok = np.flatnonzero(np.isfinite(y))
    order = sorted(ok, key=lambda j: (-y[j], index[j]))[:count]
    return [WorstRun(index=int(index[j]), seed=int(seed[j]), value=float(y[j])) for j in order]


def campaign_statistics(
    runs: pa.Table,
    methods: Sequence[str],
    *,
    confidence: float = 0.95,
    percentiles: Sequence[float] = DEFAULT_PERCENTILES,
    worst: int = 5,
    drivers: int = 3,
    touchdown: str | None = None,
) -> CampaignStatistics:
    """The statistics of a campaign's runs table (:meth:`tubempc.results.campaign_store.CampaignStore.runs`,
    the rows of the runs to count): failure bounds, percentiles, the ``worst`` runs and the top
    ``drivers`` per metric and method (the module docstring); ``touchdown``: why the runs have no
    touchdown to judge (:func:`touchdown_reason`; None: they have)."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    attempted = runs.num_rows
    if attempted == 0:
        raise ValueError("campaign statistics: no run")
    ok_mask = pc.equal(runs.column("status"), "ok").fill_null(False)
    done = runs.filter(ok_mask)
    n_failed = attempted - done.num_rows
    index = np.asarray(done.column("index").to_numpy(), dtype=float)
    seeds = [int(s) for s in done.column("seed").to_pylist()]
    names, D = _dispersions(done)
    out: dict[str, MethodStatistics] = {}
    for m in methods:
        if done.num_rows == 0 or f"{m}.J_p" not in done.column_names:
            continue
        n = done.num_rows
        exc = METRICS["max_tube_excursion"][2](done, m)
        pos, vel = _col(done, f"{m}.terminal_error.position"), _col(done, f"{m}.terminal_error.velocity")
        cone = _sum(
            _col(done, f"{m}.constraint_violations.glide_slope_steps"), _col(done, f"{m}.constraint_violations.los_steps")
        )
        inside = _col(done, f"{m}.states_inside_body")
        counted = inside is not None and bool(np.all(np.isfinite(inside)))
        outcome = done.column(f"{m}.abort.outcome").to_pylist() if f"{m}.abort.outcome" in done.column_names else None
        aborted = None if outcome is None else np.array([o == "aborted" for o in outcome], dtype=bool)
        safe = _col(done, f"{m}.abort.safe")  # null (not aborted): NaN
        landed_not_judged = np.zeros(n, dtype=bool) if aborted is None else aborted  # an abort has no touchdown
        kinds: dict[str, tuple[Array | npt.NDArray[np.bool_] | None, str | None]] = {
            "tube_exit": (None if exc is None else exc > 1.0, None),
            "touchdown": (
                None
                if pos is None or vel is None
                else ((pos > TOUCHDOWN_GOAL[0]) | (vel > TOUCHDOWN_GOAL[1])) & ~landed_not_judged,
                touchdown,
            ),
            "cone_violation": (None if cone is None else cone > 0, None),
            "inside_body": (
                None if inside is None else inside > 0,
                None if counted else "the runs did not count the states inside the body",
            ),
            "abort_unsafe": (
                None if aborted is None or safe is None else aborted & ~(np.nan_to_num(safe) > 0),
                None if aborted is not None else "the runs flew without [abort]",
            ),
        }
        failures: dict[str, FailureBound] = {}
        flags: list[npt.NDArray[np.bool_]] = []
        for name, (flag, reason) in kinds.items():
            if reason is not None or flag is None:
                failures[name] = _not_evaluated(reason or "not recorded")
                continue
            f = np.asarray(flag, dtype=bool)
            flags.append(f)
            failures[name] = failure_bound(int(f.sum()), n, confidence)
        any_failed = int(np.logical_or.reduce(flags).sum()) if flags else 0
        included = [k for k, b in failures.items() if b.evaluated]
        failures["any"] = FailureBound(
            evaluated=True,
            failures=any_failed + n_failed,
            runs=attempted,
            rate=(any_failed + n_failed) / attempted,
            upper_bound=clopper_pearson_upper(any_failed + n_failed, attempted, confidence),
            reason=f"any of {', '.join([*included, 'failed_run'])}",
        )
        metrics: dict[str, MetricStatistics] = {}
        for key, (_, _, read) in METRICS.items():
            y = read(done, m)
            if y is None or not np.any(np.isfinite(y)):
                continue
            good = np.isfinite(y)
            yv = y[good]
            drv, note = _drivers(yv, names, D[good], drivers, confidence)
            metrics[key] = MetricStatistics(
                runs=int(good.sum()),
                mean=float(np.mean(yv)),
                max=float(np.max(yv)),
                percentiles=[percentile_interval(yv, q, confidence) for q in percentiles],
                worst=_worst(y, index, seeds, worst),
                drivers=drv,
                drivers_note=note,
            )
        out[m] = MethodStatistics(failures=failures, metrics=metrics)
    return CampaignStatistics(
        confidence=confidence,
        runs_attempted=attempted,
        failed_run=failure_bound(n_failed, attempted, confidence),
        dispersions_varied=len(names),
        methods=out,
    )


def describe_bound(b: FailureBound, confidence: float) -> str:
    """One line of a failure kind: "3 of 1000 runs, < 0.775 % at 95 %" (or why it was not evaluated)."""
    if not b.evaluated or b.failures is None or b.runs is None or b.upper_bound is None:
        return f"not evaluated: {b.reason}"
    return f"{b.failures} of {b.runs} runs, < {_percent(b.upper_bound)} at {100 * confidence:g} % confidence"


def _percent(p: float) -> str:
    if p >= 0.1:
        return f"{100 * p:.3g} %"
    return f"{100 * p:.2g} %" if p >= 1e-4 else f"{p:.2g}"
