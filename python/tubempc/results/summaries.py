"""Typed summaries of the commands' results: a run (``tubempc run``: summary.json), a forgetting-factor
sweep (``tubempc sweep``: sweep.json) and a Monte Carlo campaign (``tubempc montecarlo``: summary.json).

Each summary is a frozen dataclass with ``to_json`` (the JSON-ready dict the command writes) and
``from_json``. Every file written names its ``kind`` ("run", "sweep" or "montecarlo") and its
``format_version`` (:data:`FORMAT_VERSION`); the other field names are those the files always had. A
file without ``format_version`` was written before the summaries were typed: :func:`load_summary`
reads it as format 0, the same fields, its kind told by its keys (a Monte Carlo summary counts
``runs``, a sweep has ``rows``, a run has ``methods``). A file of a newer format, another kind or a
missing or mistyped field is a ValueError naming the file and the field. A field that may be absent (a
run's ``actuation`` or ``navigation``) is None then, and left out of the file: such a field is added
without a new format (the files written before it read unchanged; a tubempc that predates it ignores
it).
"""

from __future__ import annotations

import dataclasses
import json
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, TypeVar

from .. import _core

__all__ = [
    "FORMAT_VERSION",
    "AbortSummary",
    "ActuationSummary",
    "CampaignMethodResult",
    "CampaignRunResult",
    "CampaignStatistics",
    "Comparison",
    "ConstraintViolations",
    "ControlEffort",
    "Driver",
    "EnvelopeFit",
    "FailureBound",
    "FaultSummary",
    "GroupErrors",
    "MeanSpread",
    "MethodResult",
    "MethodStatistics",
    "MetricStatistics",
    "MonteCarloMethodSummary",
    "MonteCarloSummary",
    "NavigationSummary",
    "NeesTest",
    "PercentileEstimate",
    "ReferenceSummary",
    "RunMetrics",
    "RunSummary",
    "StepTime",
    "SubsystemValues",
    "Summary",
    "SweepRow",
    "SweepSummary",
    "WorstRun",
    "fallback_steps",
    "load_summary",
    "parse_summary",
    "read_summary",
    "summary_json",
    "write_summary",
]

#: Format of the summary files this version writes (0: the files written before ``kind`` and
#: ``format_version`` existed, read as such).
FORMAT_VERSION = 1

_T = TypeVar("_T")


def fallback_steps(statuses: Mapping[str, int]) -> int:
    """Steps whose MPC status (a name of ``_core.mpc.Status``, with its count) is a fallback
    (``_core.mpc.is_fallback``)."""
    mpc = _core.mpc
    return sum(n for s, n in statuses.items() if mpc.is_fallback(mpc.Status.from_string(s)))


#: Metadata of a field that may be absent: None, and then left out of the JSON (never written as null).
_OMIT = {"omit_none": True}


def _json_name(f: dataclasses.Field[Any]) -> str:
    return str(f.metadata.get("json", f.name))


def to_json_value(value: Any) -> Any:
    """A dataclass (recursively, also inside dicts and lists) as JSON-ready dicts, lists and scalars."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out: dict[str, Any] = {}
        for f in dataclasses.fields(value):
            v = getattr(value, f.name)
            if v is None and f.metadata.get("omit_none"):
                continue
            out[_json_name(f)] = to_json_value(v)
        return out
    if isinstance(value, Mapping):
        return {str(k): to_json_value(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_json_value(v) for v in value]
    return value


def from_json_value(tp: Any, value: Any, where: str) -> Any:
    """``value`` (parsed JSON) as type ``tp``: a dataclass, dict[str, X], list[X], X | None, a scalar or
    Any; a value of another type is a ValueError naming ``where``."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        (inner,) = [a for a in args if a is not type(None)]
        return from_json_value(inner, value, where)
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        if not isinstance(value, Mapping):
            raise ValueError(f"{where}: expected an object, got {type(value).__name__}")
        hints = typing.get_type_hints(tp)
        kwargs: dict[str, Any] = {}
        for f in dataclasses.fields(tp):
            name = _json_name(f)
            if name in value:
                kwargs[f.name] = from_json_value(hints[f.name], value[name], f"{where}.{name}")
            elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise ValueError(f"{where}: missing field {name!r}")
        return tp(**kwargs)
    if origin in (dict, Mapping):
        if not isinstance(value, Mapping):
            raise ValueError(f"{where}: expected an object, got {type(value).__name__}")
        return {str(k): from_json_value(args[1], v, f"{where}.{k}") for k, v in value.items()}
    if origin is list:
        if not isinstance(value, list):
            raise ValueError(f"{where}: expected a list, got {type(value).__name__}")
        return [from_json_value(args[0], v, f"{where}[{i}]") for i, v in enumerate(value)]
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if tp in (int, bool, str):
        if not isinstance(value, tp) or (tp is int and isinstance(value, bool)):
            raise ValueError(f"{where}: expected {tp.__name__}, got {value!r}")
        return value
    raise TypeError(f"{where}: no JSON reading for type {tp!r}")  # a field type this module does not declare


class _Json:
    """to_json / from_json of a frozen dataclass (the field names are the JSON keys)."""

    def to_json(self) -> dict[str, Any]:
        """The JSON-ready dict (a field that is None and may be absent is left out)."""
        out: dict[str, Any] = to_json_value(self)
        return out

    @classmethod
    def from_json(cls: type[_T], data: Mapping[str, Any], where: str = "summary") -> _T:
        """The object of a parsed JSON dict; a missing or mistyped field is a ValueError naming it."""
        out: _T = from_json_value(cls, data, where)
        return out


@dataclass(frozen=True, kw_only=True)
class ControlEffort(_Json):
    """Sum over the steps of the input norms per group and the translational delta-v."""

    translation: float  # m/s^2
    rotation: float  # N m
    delta_v: float  # m/s


@dataclass(frozen=True, kw_only=True)
class GroupErrors(_Json):
    """An error per state group (metrics.GROUPS): m, m/s, rad, rad/s."""

    position: float
    velocity: float
    attitude: float
    angular_velocity: float


@dataclass(frozen=True, kw_only=True)
class SubsystemValues(_Json):
    """A value per subsystem (here the largest tube excursion e^T Pe^-1 e, > 1: outside the tube)."""

    translation: float
    rotation: float


@dataclass(frozen=True, kw_only=True)
class ConstraintViolations(_Json):
    """Steps of the actual trajectory violating the glide slope and the line of sight, and the largest
    constraint values (m, > 0: violated)."""

    glide_slope_steps: int
    los_steps: int
    max_glide_slope_g_m: float
    max_los_g_m: float

    @property
    def steps(self) -> int:
        """Glide-slope plus line-of-sight violating steps."""
        return self.glide_slope_steps + self.los_steps


@dataclass(frozen=True, kw_only=True)
class StepTime(_Json):
    """Statistics of a step phase's wall times (ms)."""

    median_ms: float
    p99_ms: float
    mean_ms: float
    max_ms: float


@dataclass(frozen=True, kw_only=True)
class EnvelopeFit(_Json):
    """The Theorem 2 envelope of the velocity error (metrics.velocity_convergence): C ||e_0||, rho and
    ebar when one exists, else the reason none does (never a search bound reported as a fit)."""

    exists: bool
    reason: str | None = field(default=None, metadata=_OMIT)
    C_e0_m_per_s: float | None = field(default=None, metadata=_OMIT)
    rho: float | None = field(default=None, metadata=_OMIT)
    ebar_m_per_s: float | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class ActuationSummary(_Json):
    """A run's actuators (docs/model.md M37; absent for ideal actuators): the thrusters' delta-v (sum of
    impulses / m, m/s), the net delta-v delivered (the sum of ``|u_p| dt``, m/s), propellant (kg), pulses, the wheels'
    largest total momentum (N m s), the steps per actuation status and the steps the actuators did not
    deliver (saturated, infeasible or an invalid command)."""

    thruster_delta_v: float
    net_delta_v: float
    propellant: float
    pulses: int
    max_wheel_momentum: float
    statuses: dict[str, int]
    not_delivered_steps: int


@dataclass(frozen=True, kw_only=True)
class NeesTest(_Json):
    """The run's average NEES against its two-sided chi-square bounds
    (:func:`tubempc.analysis.metrics.nees_test`): the mean of the ``steps`` = N valid per-step NEES of
    dimension ``dof`` = n, and ``[lower, upper]`` = [chi2.ppf(a/2, N n), chi2.ppf(1 - a/2, N n)] / N with
    a = 1 - ``probability``, where N n times the mean of N independent chi-square(n) samples lies with
    that probability. The steps of one run are not independent (the estimation error is correlated in
    time), so the bounds are optimistic: narrower than the mean's true spread; a mean outside them
    flags an inconsistent filter only with that caveat."""

    mean: float
    steps: int  # N: steps with a finite NEES and a navigation status "ok" or "prediction_only"
    dof: int  # n: the NEES's dimension (15: position, velocity, attitude, gyro and accelerometer biases)
    probability: float
    lower: float
    upper: float
    inside: bool  # lower <= mean <= upper


@dataclass(frozen=True, kw_only=True)
class FaultSummary(_Json):
    """A run's injected fault and its navigation's fault detection (docs/model.md M49-M50;
    :func:`tubempc.analysis.metrics.fault_summary`): the kind injected ("none": no fault), its onset (s), whether a
    fault was detected, the first detection's name ("none") and time (s), and the latency from the onset to it (s;
    None: no fault injected or none detected)."""

    injected: str
    onset: float | None = field(default=None, metadata=_OMIT)
    detected: bool
    cause: str
    detection_time: float | None = field(default=None, metadata=_OMIT)
    latency: float | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class AbortSummary(_Json):
    """How a run flown with ``[abort]`` enabled ended (docs/model.md M52; :func:`tubempc.sim.abort.abort_summary`):
    "landed" (the descent flown to the end) or "aborted", with the cause and the time (s) the abort was entered; a
    detection past the commit time, refused (the descent went on); the commit time (s; None: no certified entry);
    the truth's final height above the site's surface along its normal (m); after an entry, the truth's lowest height
    (m), its largest glide-slope g (m, <= 0 inside the cone), its states inside the body, and whether the abort ended
    safe (above ``abort.safe_altitude``, inside the cone, never inside the body); the steps flown in the abort, those
    whose tube was not certified and the largest LMI residual of its tubes (<= 0: certified)."""

    outcome: str
    cause: str
    entered_at: float | None = field(default=None, metadata=_OMIT)
    refused_cause: str
    refused_at: float | None = field(default=None, metadata=_OMIT)
    commit_time: float | None = field(default=None, metadata=_OMIT)
    final_height: float
    lowest_height: float | None = field(default=None, metadata=_OMIT)
    max_glide_slope_g: float | None = field(default=None, metadata=_OMIT)
    states_inside_body: int | None = field(default=None, metadata=_OMIT)
    safe: bool | None = field(default=None, metadata=_OMIT)
    abort_steps: int
    uncertified_steps: int
    max_residual: float | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class NavigationSummary(_Json):
    """How a run flown on navigation went (:func:`tubempc.analysis.metrics.navigation_summary`, from its
    :class:`tubempc.scenario.navigation.NavigationRecord`): the estimation error x - x^ at touchdown (the
    last step: norms per state group, the attitude's that of the phi part; m, m/s, rad, rad/s), the
    average NEES against its bounds (None: no step had a valid NEES), the camera's landmarks folded into
    the filter (total, per frame, and the fewest per frame in one control period: the period's landmarks
    over its frames, exact when the camera takes at most one frame per period; None: no frame taken, or
    a record written before the frames were counted) and the truth's gauge in the output-feedback tube
    z*_1|k (+) Omega_k (+) E_k+1 (<= 1: inside; E is a probabilistic set, so a gauge above 1 does not
    count as a lost guarantee)."""

    touchdown_error: GroupErrors
    nees: NeesTest | None = field(default=None, metadata=_OMIT)
    landmarks_used: int
    camera_frames: int | None = field(default=None, metadata=_OMIT)
    landmarks_per_frame_mean: float | None = field(default=None, metadata=_OMIT)
    landmarks_per_frame_min: float | None = field(default=None, metadata=_OMIT)
    max_gauge: SubsystemValues
    steps_outside_output_tube: int  # steps whose gauge exceeds 1 in either subsystem
    faults: FaultSummary | None = field(default=None, metadata=_OMIT)  # None: no fault injected, none detected


@dataclass(frozen=True, kw_only=True)
class MethodResult(_Json):
    """The results of one method's closed-loop run that every summary keeps (a run's
    :class:`RunMetrics`, a Monte Carlo run's :class:`CampaignMethodResult`); run_time_s is the
    machine's."""

    J_p: float
    J_r: float
    control_effort: ControlEffort
    terminal_error: GroupErrors
    rms_error: GroupErrors
    max_tube_excursion: SubsystemValues
    steps_outside_tube: int
    constraint_violations: ConstraintViolations
    statuses: dict[str, int]
    states_inside_body: int | None = field(default=None, metadata=_OMIT)  # None: not counted
    actuation: ActuationSummary | None = field(default=None, metadata=_OMIT)  # None: ideal actuators
    navigation: NavigationSummary | None = field(default=None, metadata=_OMIT)  # None: flown on the true state
    abort: AbortSummary | None = field(default=None, metadata=_OMIT)  # None: [abort] not enabled
    run_time_s: float


@dataclass(frozen=True, kw_only=True)
class RunMetrics(MethodResult):
    """Every scalar result of one closed-loop run (:func:`tubempc.analysis.metrics.run_metrics`; a run's
    summary adds ``states_inside_body``, :func:`tubempc.analysis.runner.run_summary`)."""

    fallback_steps: int | None = field(default=None, metadata=_OMIT)  # None: not recorded (count the "fallback*" statuses)
    step_time: dict[str, StepTime]
    scp_iterations_mean: float
    model_evaluations_mean: float
    active_set_qp_fraction: float
    velocity_convergence_fit: EnvelopeFit
    tube_statuses: dict[str, int] = field(default_factory=dict)
    tube_design_failures: int
    tube_uncertified_steps: int
    tube_feasible_every_step: bool
    seed: int


@dataclass(frozen=True, kw_only=True)
class ReferenceSummary(_Json):
    """The reference trajectory's solve (tubempc.scenario.reference)."""

    cost: float
    iterations: int
    converged: bool
    last_subproblem: str = "optimal"
    max_defect: float
    solve_time_s: float


@dataclass(frozen=True, kw_only=True)
class Comparison(_Json):
    """TBMPC-FFA against TBMPC in one run."""

    J_p_reduction_percent: float


@dataclass(frozen=True, kw_only=True)
class RunSummary(_Json):
    """A run's summary.json (``tubempc run``, :func:`tubempc.analysis.runner.run_methods`)."""

    KIND: ClassVar[str] = "run"
    tubempc_version: str
    config_hash: str
    seed: int
    shape: str
    shape_file: dict[str, Any] | None  # the pinned shape's file and sha256 (tubempc.results.pinning); None: generated
    n_faces: int
    machine: dict[str, Any]
    reference: ReferenceSummary
    methods: dict[str, RunMetrics]
    comparison: Comparison | None = field(default=None, metadata=_OMIT)  # both methods flown
    plant: str | None = field(default=None, metadata=_OMIT)  # simulation.plant; None: a file before it (the project's)
    figure_errors: dict[str, str] | None = field(default=None, metadata=_OMIT)  # figures not drawn: file -> error
    format_version: int = field(default=FORMAT_VERSION, compare=False)  # of the file it was read from


@dataclass(frozen=True, kw_only=True)
class SweepRow(RunMetrics):
    """One case of a sweep: a run's metrics, its forgetting factors (absent for TBMPC) and the mean
    translational tube half-width sqrt(Pe_p[0, 0]) (m)."""

    lambda_p: float | None = field(default=None, metadata=_OMIT)
    lambda_r: float | None = field(default=None, metadata=_OMIT)
    mean_tube_half_width_x_m: float | None = field(default=None, metadata=_OMIT)

    @classmethod
    def of(
        cls,
        metrics: RunMetrics,
        *,
        mean_tube_half_width_x_m: float,
        lambda_p: float | None = None,
        lambda_r: float | None = None,
    ) -> SweepRow:
        """A run's metrics as a sweep row."""
        base = {f.name: getattr(metrics, f.name) for f in dataclasses.fields(RunMetrics)}
        return cls(**base, lambda_p=lambda_p, lambda_r=lambda_r, mean_tube_half_width_x_m=mean_tube_half_width_x_m)


@dataclass(frozen=True, kw_only=True)
class SweepSummary(_Json):
    """A sweep's sweep.json (``tubempc sweep``, :func:`tubempc.analysis.sweep`; paper Table 3)."""

    KIND: ClassVar[str] = "sweep"
    seed: int
    config_hash: str
    shape_file: dict[str, Any] | None
    machine: dict[str, Any]
    rows: dict[str, SweepRow]
    # of the lambda_p swept: the smallest whose TBMPC-FFA flew a designed or certified tube at every step
    smallest_feasible_lambda_p: float | None
    plant: str | None = field(default=None, metadata=_OMIT)  # simulation.plant; None: a file before it (the project's)
    format_version: int = field(default=FORMAT_VERSION, compare=False)

    @property
    def ffa_rows(self) -> list[SweepRow]:
        """The TBMPC-FFA rows (those with a lambda_p)."""
        return [r for r in self.rows.values() if r.lambda_p is not None]


@dataclass(frozen=True, kw_only=True)
class CampaignMethodResult(MethodResult):
    """What a Monte Carlo run keeps per method (its ``<method>.*`` columns in the campaign's store,
    :mod:`tubempc.results.campaign_store`): the fields of :class:`MethodResult`."""

    @classmethod
    def of(cls, metrics: RunMetrics) -> CampaignMethodResult:
        """The fields of a run's metrics a campaign keeps."""
        return cls(**{f.name: getattr(metrics, f.name) for f in dataclasses.fields(cls)})

    @property
    def fallback_steps(self) -> int:
        """Steps whose status is a fallback."""
        return fallback_steps(self.statuses)


@dataclass(frozen=True)
class CampaignRunResult:
    """A Monte Carlo run's result (its row in the campaign's store, unflattened): per method its metrics, and the
    dispersions the run applied (the same for every method; None in records written before they were
    kept). JSON layout: {"<method>": {...}, ..., "applied": {...}}."""

    methods: dict[str, CampaignMethodResult]
    applied: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {m: r.to_json() for m, r in self.methods.items()}
        if self.applied is not None:
            out["applied"] = self.applied
        return out

    @classmethod
    def from_json(cls, data: Mapping[str, Any], where: str = "result") -> CampaignRunResult:
        methods = {m: CampaignMethodResult.from_json(v, f"{where}.{m}") for m, v in data.items() if m != "applied"}
        applied = data.get("applied")
        return cls(methods=methods, applied=None if applied is None else dict(applied))


@dataclass(frozen=True, kw_only=True)
class MeanSpread(_Json):
    """Mean and 3 standard deviations (sample, ddof 1; 0 for one run) over a campaign's runs."""

    mean: float
    three_sigma: float = field(metadata={"json": "3sigma"})


@dataclass(frozen=True, kw_only=True)
class MonteCarloMethodSummary(_Json):
    """One method over a campaign (paper Table 4)."""

    J_p: MeanSpread
    J_r: MeanSpread
    runs_outside_tube: int
    max_tube_excursion: float
    runs_with_cone_violation: int
    terminal_position_error_max_m: float
    runs_inside_body: int
    # runs that lost a guarantee (tube left, fallback steps, a state inside the body): exit status 4
    runs_guarantee_lost: int
    # of the runs flown on navigation with a NEES, those whose average NEES lies inside its bounds
    # (NeesTest; None: no such run)
    nees_inside_fraction: float | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class FailureBound(_Json):
    """A failure kind over a campaign (:mod:`tubempc.analysis.statistics`): ``failures`` of ``runs``,
    the observed ``rate`` and the one-sided Clopper-Pearson ``upper_bound`` on its probability at the
    statistics' confidence; or, not ``evaluated``, the ``reason`` (a kind that cannot be judged is not
    reported as 0). For the kind "any", ``reason`` lists the kinds it joins."""

    evaluated: bool
    failures: int | None = field(default=None, metadata=_OMIT)
    runs: int | None = field(default=None, metadata=_OMIT)
    rate: float | None = field(default=None, metadata=_OMIT)
    upper_bound: float | None = field(default=None, metadata=_OMIT)
    reason: str | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class PercentileEstimate(_Json):
    """A percentile of a metric over the runs (``value``, interpolated) with its distribution-free
    confidence interval [``lower``, ``upper``] of order statistics, of exact binomial ``coverage`` (>= the
    statistics' confidence); an end is None when the runs are too few for it."""

    percent: float
    value: float
    lower: float | None = field(default=None, metadata=_OMIT)
    upper: float | None = field(default=None, metadata=_OMIT)
    coverage: float | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class WorstRun(_Json):
    """A run among the worst by a metric: its index and seed (``tubempc run --from-campaign DIR --index
    I`` re-flies it alone) and its value."""

    index: int
    seed: int
    value: float


@dataclass(frozen=True, kw_only=True)
class Driver(_Json):
    """An applied dispersion (its column in the campaign's store) and its Spearman rank correlation with a
    metric over the runs, with the p-value of no correlation; ``significant``: p below (1 - confidence)
    over the number of dispersions tested (Bonferroni)."""

    dispersion: str
    rho: float
    p_value: float
    significant: bool


@dataclass(frozen=True, kw_only=True)
class MetricStatistics(_Json):
    """A metric of one method over a campaign's runs: its mean and largest value, percentiles with their
    confidence intervals, the worst runs and the dispersions that drive it most (empty, with
    ``drivers_note`` saying why, when none can be ranked)."""

    runs: int
    mean: float
    max: float
    percentiles: list[PercentileEstimate]
    worst: list[WorstRun]
    drivers: list[Driver]
    drivers_note: str | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class MethodStatistics(_Json):
    """A method's failure kinds (tubempc.analysis.statistics.FAILURE_KINDS) and metrics."""

    failures: dict[str, FailureBound]
    metrics: dict[str, MetricStatistics]


@dataclass(frozen=True, kw_only=True)
class CampaignStatistics(_Json):
    """What a review board asks of a campaign (:mod:`tubempc.analysis.statistics`): per method the
    failure bounds and the metrics' statistics, the campaign's failed runs, at ``confidence``; the
    number of applied dispersions that varied (the drivers' candidates)."""

    confidence: float
    runs_attempted: int
    failed_run: FailureBound
    dispersions_varied: int
    methods: dict[str, MethodStatistics]


@dataclass(frozen=True, kw_only=True)
class MonteCarloSummary(_Json):
    """A campaign's summary.json (``tubempc montecarlo``, :func:`tubempc.analysis.studies`)."""

    KIND: ClassVar[str] = "montecarlo"
    runs: int  # successful runs
    failed_runs: list[int]
    methods: dict[str, MonteCarloMethodSummary]
    J_p_mean_reduction_percent: float | None = field(default=None, metadata=_OMIT)  # both methods flown
    master_seed: int
    config_hash: str
    executed_now: int = 0
    wall_time_s: float = 0.0
    workers: int | None = None
    scheduler: str | None = None
    machine: dict[str, Any] = field(default_factory=dict)
    plant: str | None = field(default=None, metadata=_OMIT)  # simulation.plant; None: a file before it (the project's)
    statistics: CampaignStatistics | None = field(default=None, metadata=_OMIT)  # None: a file before them
    format_version: int = field(default=FORMAT_VERSION, compare=False)


Summary = RunSummary | SweepSummary | MonteCarloSummary
_KINDS: dict[str, type[RunSummary] | type[SweepSummary] | type[MonteCarloSummary]] = {
    c.KIND: c for c in (RunSummary, SweepSummary, MonteCarloSummary)
}


def summary_json(summary: Summary) -> dict[str, Any]:
    """The file's dict: the summary's fields, its ``kind`` and this version's ``format_version``."""
    return {**summary.to_json(), "kind": summary.KIND, "format_version": FORMAT_VERSION}


def write_summary(path: Path, summary: Summary) -> Path:
    """Writes ``summary`` (sorted keys, indented) to ``path``; returns the path."""
    path.write_text(json.dumps(summary_json(summary), indent=1, sort_keys=True))
    return path


def parse_summary(data: Mapping[str, Any], where: str = "summary") -> Summary:
    """A summary of a parsed file (see the module docstring for format 0)."""
    if not isinstance(data, Mapping):
        raise ValueError(f"{where}: not a tubempc summary (not a JSON object)")
    version = data.get("format_version", 0)
    if isinstance(version, bool) or not isinstance(version, int) or not 0 <= version <= FORMAT_VERSION:
        raise ValueError(
            f"{where}: format_version {version!r} is not one this tubempc reads (0-{FORMAT_VERSION}; a newer tubempc "
            "wrote it?)"
        )
    if version == 0:
        kind = "montecarlo" if "runs" in data else "sweep" if "rows" in data else "run" if "methods" in data else None
    else:
        kind = data.get("kind")
    cls = _KINDS.get(str(kind))
    if cls is None:
        raise ValueError(f"{where}: not a tubempc summary (kind {kind!r}; expected one of {sorted(_KINDS)})")
    body = {k: v for k, v in data.items() if k not in ("kind", "format_version")}
    return dataclasses.replace(cls.from_json(body, where), format_version=version)


def load_summary(path: str | Path) -> Summary:
    """The summary in ``path`` (a run's or campaign's summary.json, a sweep's sweep.json)."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{p}: not a tubempc summary ({exc})") from exc
    return parse_summary(data, str(p))


def read_summary(path: str | Path, cls: type[_T]) -> _T:
    """The summary in ``path``, which must be of type ``cls`` (RunSummary, SweepSummary or
    MonteCarloSummary)."""
    s = load_summary(path)
    if not isinstance(s, cls):
        raise ValueError(f"{path}: a {s.KIND} summary, not a {getattr(cls, 'KIND', cls.__name__)} summary")
    return s
