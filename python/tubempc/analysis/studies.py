"""Monte Carlo campaigns (paper Table 4, Figures 17-18) and the forgetting-factor sweep (Table 3,
Figures 15-16), on top of :mod:`tubempc.scenario`, :mod:`tubempc.sim.closed_loop`, :mod:`tubempc.analysis.metrics`
and :mod:`tubempc.analysis.campaign`."""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
from matplotlib.figure import Figure

from ..config import Config, load_config
from ..design.library import SharedDesigns, adopt_shared_designs, shared_designs
from ..results.campaign_store import CampaignStore, RunOutput, differing_columns, differing_steps, flatten
from ..results.machine import machine_info
from ..results.pinning import pin_config, shape_record
from ..results.records import RunRecord, save_record
from ..results.summaries import (
    CampaignMethodResult,
    CampaignRunResult,
    MeanSpread,
    MonteCarloMethodSummary,
    MonteCarloSummary,
    SweepRow,
    SweepSummary,
    fallback_steps,
    write_summary,
)
from ..scenario.build import METHODS, Scenario, build_scenario
from ..scenario.sites import site_map, tangent_axes
from ..sim.closed_loop import simulate
from . import figures
from .campaign import CampaignResult, run_campaign
from .claims import TOUCHDOWN_GOAL
from .runner import guarantee_lost, run_summary
from .statistics import DEFAULT_PERCENTILES, campaign_statistics, touchdown_reason

__all__ = [
    "MONTECARLO_METRICS",
    "TOUCHDOWN_ERROR",
    "Reflight",
    "campaign_run_output",
    "campaign_run_result",
    "dispersion_figure",
    "fly_campaign_run",
    "montecarlo",
    "montecarlo_summary",
    "refly_montecarlo_run",
    "sweep",
    "touchdown_offsets",
]

_SCENARIOS: dict[str, Scenario] = {}


def _scenario(cfg: Config, cache_dir: str) -> Scenario:
    """The scenario of a configuration, built once per process."""
    key = f"{cfg.hash()}|{cache_dir}"
    if key not in _SCENARIOS:
        _SCENARIOS[key] = build_scenario(cfg, cache_dir=cache_dir)
    return _SCENARIOS[key]


#: The metrics a Monte Carlo run keeps per method (its ``<method>.*`` columns in the campaign's store,
#: :class:`tubempc.results.summaries.CampaignMethodResult`; run_time_s is the machine's).
MONTECARLO_METRICS = tuple(f.name for f in dataclasses.fields(CampaignMethodResult))


def fly_campaign_run(
    cfg: Config, scn: Scenario, methods: tuple[str, ...], max_steps: int | None, tube_threads: int, seed: int
) -> tuple[CampaignRunResult, dict[str, RunRecord]]:
    """Every method with disturbance seed ``seed`` as a campaign flies it (in a physical environment, the truth
    dispersed from the seed): the run's result (metrics per method and the dispersions applied) and the records."""
    # The campaign's processes fill the cores: background designs run inline, with the same numbers
    # when their adoption is deterministic (tube_policy.py).
    worker = "inline" if cfg.tube.design_adoption == "deterministic" else None
    out: dict[str, CampaignMethodResult] = {}
    applied: dict[str, Any] | None = None
    records: dict[str, RunRecord] = {}
    for m in methods:
        rec = simulate(scn, m, seed, max_steps=max_steps, tube_threads=tube_threads, design_worker=worker, dispersed=True)
        out[m] = CampaignMethodResult.of(run_summary(scn, rec))
        applied = rec.applied  # the same for every method: one seed, one sequence of draws
        records[m] = rec
    return CampaignRunResult(methods=out, applied=applied), records


def campaign_run_output(flown: CampaignRunResult, records: dict[str, RunRecord]) -> RunOutput:
    """A campaign run as the store keeps it: its result (metrics per method, the dispersions applied and,
    for runs flown on navigation, ``nav_touchdown_error.<method>``: x_T - x_f, 12 values) and per method
    the per-step arrays: the error x - z (T, 12) and the tube half-widths sqrt(diag Pe) (T, 12), float32,
    and the navigation's (:meth:`tubempc.scenario.navigation.NavigationRecord.campaign_arrays`)."""
    result = flown.to_json()
    steps: dict[str, dict[str, np.ndarray]] = {}
    for m, rec in records.items():
        arrays = {
            "error": (rec.x[:-1] - rec.z).astype(np.float32),
            "half_width": np.sqrt(
                np.concatenate([np.diagonal(rec.Pe_p, axis1=1, axis2=2), np.diagonal(rec.Pe_r, axis1=1, axis2=2)], axis=1)
            ).astype(np.float32),
        }
        if rec.navigation is not None:  # flown on the estimate: the navigation's per-step record
            arrays.update({k: np.asarray(v, dtype=np.float32) for k, v in rec.navigation.campaign_arrays().items()})
            result.setdefault(TOUCHDOWN_ERROR, {})[m] = (rec.x[-1] - rec.zbar[-1]).tolist()  # the dispersion
        steps[m] = arrays
    return RunOutput(result, steps)


#: The key of a run's result holding, per method flown on navigation, x_T - x_f (12 values).
TOUCHDOWN_ERROR = "nav_touchdown_error"


def campaign_run_result(result: dict[str, Any], where: str = "result") -> CampaignRunResult:
    """A stored run's result (:meth:`tubempc.results.campaign_store.CampaignStore.result`) as its
    :class:`tubempc.results.summaries.CampaignRunResult`."""
    return CampaignRunResult.from_json({k: v for k, v in result.items() if k != TOUCHDOWN_ERROR}, where)


def _montecarlo_run(
    cfg: Config,
    cache_dir: str,
    methods: tuple[str, ...],
    max_steps: int | None,
    tube_threads: int,
    designs: SharedDesigns,
    index: int,
    seed: int,
) -> RunOutput:
    """One Monte Carlo run: every method with the same disturbance seed, on the set-up designs the
    campaign made once (``designs``); its metrics, the dispersions applied and its per-step arrays for the
    campaign's store (:func:`campaign_run_output`)."""
    scn = _scenario(cfg, cache_dir)
    adopt_shared_designs(scn, designs)
    out, records = fly_campaign_run(cfg, scn, methods, max_steps, tube_threads, seed)
    return campaign_run_output(out, records)


@dataclass(frozen=True)
class Reflight:
    """A campaign run flown again (refly.json): its J_p and J_r per method, the guarantees it lost, and
    what differs from the campaign's record (``equal``: nothing, to the bit)."""

    campaign: str
    index: int
    seed: int
    methods: dict[str, dict[str, float]]  # method -> {"J_p": ..., "J_r": ...}
    guarantee_lost: dict[str, list[str]]
    differences: list[str]
    machine: dict[str, Any]

    @property
    def equal(self) -> bool:
        return not self.differences

    def to_json(self) -> dict[str, Any]:
        return {**dataclasses.asdict(self), "equal": self.equal}


def refly_montecarlo_run(campaign_dir: Path, index: int, out: Path) -> Reflight:
    """Flies run ``index`` of the campaign in ``campaign_dir`` again, alone, from its configuration and
    its record's seed and cut, writes ``out/<method>.h5`` and ``out/refly.json`` and returns the
    comparison: every column of its row in the campaign's store (metrics, dispersions; not the run
    times) and its per-step arrays against the re-flight's, with ``equal`` True when all are the same
    to the bit."""
    store = CampaignStore(campaign_dir)
    where = f"{store.runs_dir}: run {index}"
    row = store.row(index)
    if row["status"] != "ok":
        raise ValueError(f"{where} failed in the campaign: {row.get('error')}")
    stored = store.result(index)
    result = campaign_run_result(stored, where)
    if result.applied is None:
        raise ValueError(f"{where}: written before runs recorded their dispersions; rerun the campaign")
    cfg = load_config(campaign_dir / "config.toml")
    manifest_path = campaign_dir / "campaign.json"
    manifest = json.loads(manifest_path.read_text(encoding="utf-8")) if manifest_path.exists() else {}
    differences: list[str] = []
    if manifest.get("config_hash") != cfg.hash():
        differences.append(
            f"config.toml (its hash {cfg.hash()[:12]} is not the campaign's {str(manifest.get('config_hash'))[:12]})"
        )
    pinned = manifest.get("shape_file")
    if pinned is not None:
        now = shape_record(cfg)
        if now is None or now["sha256"] != pinned["sha256"]:
            differences.append(f"shape file {cfg.asteroid.shape} (its sha256 is not the campaign's)")
    methods = tuple(m for m in METHODS if m in result.methods)
    scn = build_scenario(cfg, cache_dir=campaign_dir / "cache")
    flown, records = fly_campaign_run(cfg, scn, methods, result.applied.get("max_steps"), 1, int(str(row["seed"])))
    out.mkdir(parents=True, exist_ok=True)
    for m, rec in records.items():
        save_record(out / f"{m}.h5", rec, config=cfg.to_dict(), metadata=flown.methods[m].to_json())
    output = campaign_run_output(flown, records)
    differences += differing_columns(row, flatten(output.result), ignore=("run_time_s",))
    differences += [f"steps:{d}" for d in differing_steps(store.steps(index), output.steps)]
    comparison = Reflight(
        campaign=str(campaign_dir),
        index=index,
        seed=int(str(row["seed"])),
        methods={m: {"J_p": flown.methods[m].J_p, "J_r": flown.methods[m].J_r} for m in methods},
        guarantee_lost={m: guarantee_lost(flown.methods[m]) for m in methods},
        differences=differences,
        machine=machine_info(),
    )
    (out / "refly.json").write_text(json.dumps(comparison.to_json(), indent=1, sort_keys=True))
    return comparison


def _fallbacks(runs: pa.Table, method: str) -> np.ndarray:
    """Fallback steps per run (the statuses that are fallbacks, :func:`tubempc.results.summaries.fallback_steps`)."""
    prefix = f"{method}.statuses."
    total = np.zeros(runs.num_rows)
    for name in runs.column_names:
        if name.startswith(prefix) and fallback_steps({name[len(prefix) :]: 1}):
            total += np.nan_to_num(_column(runs, name))
    return total


def _column(runs: pa.Table, name: str) -> np.ndarray:
    """A numeric column (null: NaN; absent: all NaN; integers beyond 2^53 rounded to the nearest double)."""
    if name not in runs.column_names or pa.types.is_null(runs.column(name).type):
        return np.full(runs.num_rows, np.nan)
    return np.asarray(runs.column(name).cast(pa.float64(), safe=False).to_numpy(zero_copy_only=False), dtype=float)


def _method_summary(runs: pa.Table, m: str) -> MonteCarloMethodSummary:
    """Table 4's row of method ``m`` over the completed runs' rows (vectorised over the store's columns;
    the same numbers as :func:`tubempc.analysis.runner.guarantee_lost` and the per-run results give)."""

    def c(name: str) -> np.ndarray:
        return _column(runs, f"{m}.{name}")

    jp, jr = c("J_p"), c("J_r")
    exc = np.maximum(c("max_tube_excursion.translation"), c("max_tube_excursion.rotation"))
    inside = np.nan_to_num(c("states_inside_body"))
    lost = (
        (c("steps_outside_tube") > 0)
        | (_fallbacks(runs, m) > 0)
        | (inside > 0)
        | (np.nan_to_num(c("actuation.not_delivered_steps")) > 0)
    )
    nees = c("navigation.nees.inside")
    nees = nees[np.isfinite(nees)]
    return MonteCarloMethodSummary(
        J_p=MeanSpread(mean=float(jp.mean()), three_sigma=float(3 * jp.std(ddof=1)) if jp.size > 1 else 0.0),
        J_r=MeanSpread(mean=float(jr.mean()), three_sigma=float(3 * jr.std(ddof=1)) if jr.size > 1 else 0.0),
        runs_outside_tube=int(np.sum(exc > 1.0)),
        max_tube_excursion=float(exc.max()),
        runs_with_cone_violation=int(
            np.sum(c("constraint_violations.glide_slope_steps") + c("constraint_violations.los_steps") > 0)
        ),
        terminal_position_error_max_m=float(c("terminal_error.position").max()),
        runs_inside_body=int(np.sum(inside > 0)),
        runs_guarantee_lost=int(np.sum(lost)),
        nees_inside_fraction=float(np.mean(nees)) if nees.size else None,
    )


def montecarlo_summary(
    campaign: CampaignResult,
    methods: tuple[str, ...],
    *,
    master_seed: int,
    config_hash: str,
    wall_time_s: float,
    n_runs: int | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    plant: str | None = None,
    confidence: float = 0.95,
    percentiles: tuple[float, ...] = DEFAULT_PERCENTILES,
    touchdown: str | None = "the caller did not say whether the runs end in a touchdown",
) -> MonteCarloSummary:
    """Table 4 (mean and 3 sigma of J_p and J_r per method), the runs that ever left the tube, for runs
    flown on navigation the fraction whose average NEES lies inside its bounds, and the campaign's
    statistics (:func:`tubempc.analysis.statistics.campaign_statistics`: failure bounds at
    ``confidence``, ``percentiles``, worst runs, drivers; ``touchdown`` why the runs have no touchdown
    to judge, None: they have), over the stored runs of index below ``n_runs`` (default: every one)."""
    runs = campaign.store.runs()
    if n_runs is not None:
        runs = runs.filter(pc.less(runs.column("index"), n_runs))
    done = runs.filter(pc.equal(runs.column("status"), "ok"))
    per_method = {m: _method_summary(done, m) for m in methods if done.num_rows and f"{m}.J_p" in done.column_names}
    reduction = None
    if {"tbmpc", "ffa"} <= set(per_method):
        reduction = 100.0 * (1.0 - per_method["ffa"].J_p.mean / per_method["tbmpc"].J_p.mean)
    statistics = None
    if runs.num_rows:
        statistics = campaign_statistics(runs, methods, confidence=confidence, percentiles=percentiles, touchdown=touchdown)
    failed = runs.filter(pc.equal(runs.column("status"), "failed"))
    return MonteCarloSummary(
        runs=done.num_rows,
        failed_runs=[int(i) for i in failed.column("index").to_pylist()],
        methods=per_method,
        J_p_mean_reduction_percent=reduction,
        master_seed=master_seed,
        config_hash=config_hash,
        executed_now=len(campaign.executed),
        wall_time_s=wall_time_s,
        workers=workers,
        scheduler=scheduler,
        machine=machine_info(),
        plant=plant,
        statistics=statistics,
    )


def montecarlo(
    cfg: Config,
    runs: int,
    out: Path,
    *,
    master_seed: int = 0,
    workers: int | None = None,
    scheduler: str | None = None,
    batch_size: int | None = None,
    methods: tuple[str, ...] = METHODS,
    retry_failed: bool = False,
    only: list[int] | None = None,
    progress: bool = True,
    max_steps: int | None = None,
    confidence: float = 0.95,
    percentiles: tuple[float, ...] = DEFAULT_PERCENTILES,
) -> MonteCarloSummary:
    """Runs (or resumes) a campaign into ``out`` (its store, :mod:`tubempc.results.campaign_store`) and
    writes ``out/summary.json`` (with the statistics at ``confidence`` and ``percentiles``) and the
    figures. ``batch_size``: runs per worker task (default
    :func:`tubempc.analysis.campaign.default_batch_size`).

    ``max_steps`` cuts every run short (quick checks); None runs the whole mission."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    bad = [p for p in percentiles if not 0.0 < p < 100.0]
    if bad:
        raise ValueError(f"percentiles must lie in (0, 100), got {bad}")
    out.mkdir(parents=True, exist_ok=True)
    CampaignStore(out)  # a folder of the layout before the store: refused before anything is written
    cfg = pin_config(cfg, out)  # the folder keeps its shape file: it re-flies wherever it is copied
    cache = out / "cache"
    scn = build_scenario(cfg, cache_dir=cache)  # the reference once, before the workers read it from the cache
    cfg.save(out / "config.toml")
    # Several runs at once already occupy the cores: then each run designs its two tubes sequentially.
    parallel_runs = scheduler is not None or (workers or os.cpu_count() or 1) > 1
    # The set-up that no run's dispersion changes, made once here for every worker: the reference (in the
    # cache) and the methods' LMI designs and tube library.
    designs = shared_designs(scn, tuple(methods))
    fn = functools.partial(_montecarlo_run, cfg, str(cache), tuple(methods), max_steps, 1 if parallel_runs else 2, designs)
    t0 = time.perf_counter()
    camp = run_campaign(
        fn,
        runs,
        out,
        master_seed,
        config_hash=cfg.hash(),
        shape_file=shape_record(cfg),
        workers=workers,
        scheduler=scheduler,
        batch_size=batch_size,
        retry_failed=retry_failed,
        only=only,
        progress=progress,
    )
    b = cfg.boundary
    summary = montecarlo_summary(
        camp,
        tuple(methods),
        master_seed=master_seed,
        config_hash=cfg.hash(),
        wall_time_s=time.perf_counter() - t0,
        n_runs=runs,
        workers=workers,
        scheduler=scheduler,
        plant=cfg.simulation.plant,
        confidence=confidence,
        percentiles=percentiles,
        touchdown=touchdown_reason(b.terminal, b.touchdown_speed, cfg.mpc.n_steps, max_steps),
    )
    write_summary(out / "summary.json", summary)
    _envelope_figures(cfg, camp.store, out, tuple(methods))
    for m in methods:  # a campaign flown on navigation to a site: the touchdown dispersion on the site map
        fig = dispersion_figure(scn, out, m)
        if fig is not None:
            figures.save(fig, out / f"fig21_touchdown_{m}.png")
    return summary


def touchdown_offsets(scn: Scenario, out: Path, method: str) -> np.ndarray:
    """The touchdown offsets of ``method``'s runs in the campaign folder ``out`` (those that kept
    ``nav_touchdown_error.<method>``, x_T - x_f, in the store: runs flown on navigation): (n, 2) (east,
    north) (m) in the site's tangent plane (:func:`tubempc.scenario.sites.tangent_axes`), the position
    error taken from L to A at t_f. Empty without a site or such runs."""
    if scn.site is None:
        return np.zeros((0, 2))
    runs = CampaignStore(out).runs()
    runs = runs.filter(pc.equal(runs.column("status"), "ok"))
    cols = [f"{TOUCHDOWN_ERROR}.{method}[{i}]" for i in range(3)]
    if not all(c in runs.column_names for c in cols):
        return np.zeros((0, 2))
    dr_L = np.column_stack([_column(runs, c) for c in cols])
    dr_L = dr_L[np.all(np.isfinite(dr_L), axis=1)]
    C_AL = np.asarray(scn.model.C_AL(scn.config.mpc.t_f))
    east, north = tangent_axes(scn.site.normal_A)
    dr_A = dr_L @ C_AL.T
    return np.column_stack([dr_A @ east, dr_A @ north]).reshape(-1, 2)


def dispersion_figure(scn: Scenario, out: Path, method: str, probability: float = 0.997) -> Figure | None:
    """The touchdown dispersion of ``method`` in the campaign folder ``out`` on the site map
    (:func:`tubempc.analysis.figures.touchdown_dispersion`): the ellipse of ``probability``, the goal circle
    (:data:`tubempc.analysis.claims.TOUCHDOWN_GOAL`), the shape's facets and the camera's landmarks within
    ``navigation.site_landmark_radius`` (m; wider when the touchdowns spread further). None without a
    site or runs flown on navigation."""
    offsets = touchdown_offsets(scn, out, method)
    if scn.site is None or len(offsets) == 0:
        return None
    from ..scenario.navigation import landmark_catalogue

    radius = max(scn.config.navigation.site_landmark_radius, 2.0 * float(np.max(np.abs(offsets))))
    landmarks_A = np.array([lm.p_A for lm in landmark_catalogue(scn)])
    site = site_map(scn.shape, scn.site, radius, landmarks_A)
    name = {"tbmpc": "TBMPC", "ffa": "TBMPC-FFA"}.get(method, method)
    return figures.touchdown_dispersion(
        offsets, f"{name}, {len(offsets)} runs", probability, TOUCHDOWN_GOAL[0], site_map=site
    )


#: Runs whose error trajectories the envelope figures draw (the first by index; the largest tube
#: half-width is taken over every run).
ENVELOPE_RUNS = 300


def _envelope_figures(cfg: Config, store: CampaignStore, out: Path, methods: tuple[str, ...]) -> None:
    t = np.arange(cfg.mpc.n_steps + 1) * cfg.mpc.dt
    err_cols = [f"error[{j}]" for j in range(12)]
    hw_cols = [f"half_width[{j}]" for j in range(12)]
    drawn_runs = set(store.indices("ok")[:ENVELOPE_RUNS])
    for m in methods:
        errs: dict[int, np.ndarray] = {}
        hw = np.full((0, 12), -np.inf)  # the largest half-width per step over every run
        runs: set[int] = set()
        for part in store.iter_steps(m, [*err_cols, *hw_cols]):  # one part file at a time
            if not set(err_cols + hw_cols) <= set(part.column_names):
                continue
            part = part.filter(pc.is_valid(part.column(hw_cols[0]))).sort_by([("index", "ascending"), ("step", "ascending")])
            idx, step = part.column("index").to_numpy(), part.column("step").to_numpy()
            w = np.column_stack([part.column(c).to_numpy(zero_copy_only=False) for c in hw_cols]).astype(float)
            if len(step) and step.max() >= len(hw):
                hw = np.vstack([hw, np.full((step.max() + 1 - len(hw), 12), -np.inf)])
            np.maximum.at(hw, step, w)
            runs.update(int(i) for i in np.unique(idx))
            for i in sorted(drawn_runs & set(np.unique(idx).tolist())):
                rows = idx == i
                errs[i] = np.column_stack([part.column(c).filter(pa.array(rows)).to_numpy() for c in err_cols]).astype(float)
        if not errs:
            continue
        drawn = [errs[i] for i in sorted(errs)]
        shown = (
            f"{len(runs)} Monte Carlo runs" if len(drawn) == len(runs) else f"{len(drawn)} of {len(runs)} Monte Carlo runs"
        )
        translation = ["x (m)", "y (m)", "z (m)", "vx (m/s)", "vy (m/s)", "vz (m/s)"]
        for tag, sl, labels in (
            ("17_translation", slice(0, 6), translation),
            (
                "18_rotation",
                slice(6, 12),
                ["phi_x (rad)", "phi_y (rad)", "phi_z (rad)", "omega_x (rad/s)", "omega_y (rad/s)", "omega_z (rad/s)"],
            ),
        ):
            figures.save(
                figures.montecarlo_envelopes(
                    t, [e[:, sl] for e in drawn], hw[:, sl], labels, f"{m}: {shown}, x - z against the tube"
                ),
                out / f"fig{tag}_{m}.png",
            )


def sweep(
    cfg: Config, lambdas_p: list[float], lambdas_r: list[float] | None, out: Path, *, seed: int = 0, progress: bool = True
) -> SweepSummary:
    """Table 3: TBMPC and TBMPC-FFA at each (lambda_p, lambda_r); Figures 15-16 (error and tube
    half-width of x and phi_x against lambda)."""
    if lambdas_r is not None and len(lambdas_r) != len(lambdas_p):
        raise ValueError("--lambda-r needs as many values as --lambda-p")
    pairs = list(zip(lambdas_p, lambdas_r or [cfg.identification.lambda_r] * len(lambdas_p), strict=True))
    for lp, lr in pairs:
        for name, v in (("lambda_p", lp), ("lambda_r", lr)):
            if not 0.0 < v < 1.0:
                raise ValueError(f"{name} must lie in (0, 1), got {v}")
    out.mkdir(parents=True, exist_ok=True)
    cfg = pin_config(cfg, out)
    scn = build_scenario(cfg, cache_dir=out / "cache")
    cfg.save(out / "config.toml")
    rows: dict[str, SweepRow] = {}
    rec = simulate(scn, "tbmpc", seed, progress=progress)
    tube_half_x = float(np.mean(np.sqrt(rec.Pe_p[:, 0, 0])))
    rows["TBMPC"] = SweepRow.of(run_summary(scn, rec), mean_tube_half_width_x_m=tube_half_x)
    err_x: dict[str, np.ndarray] = {"TBMPC": rec.x[:, 0] - rec.zbar[:, 0]}
    err_phi: dict[str, np.ndarray] = {"TBMPC": rec.x[:, 6] - rec.zbar[:, 6]}
    tube_x = {"TBMPC": np.sqrt(rec.Pe_p[:, 0, 0])}
    tube_phi = {"TBMPC": np.sqrt(rec.Pe_r[:, 0, 0])}
    for lp, lr in pairs:
        label = f"FFA lambda_p={lp:g}, lambda_r={lr:g}"
        r = simulate(scn, "ffa", seed, progress=progress, lambda_p=lp, lambda_r=lr)
        rows[label] = SweepRow.of(
            run_summary(scn, r),
            lambda_p=lp,
            lambda_r=lr,
            mean_tube_half_width_x_m=float(np.mean(np.sqrt(r.Pe_p[:, 0, 0]))),
        )
        err_x[label] = r.x[:, 0] - r.zbar[:, 0]
        err_phi[label] = r.x[:, 6] - r.zbar[:, 6]
        tube_x[label] = np.sqrt(r.Pe_p[:, 0, 0])
        tube_phi[label] = np.sqrt(r.Pe_r[:, 0, 0])
    feasible = [r.lambda_p for r in rows.values() if r.lambda_p is not None and r.tube_feasible_every_step]
    summary = SweepSummary(
        seed=seed,
        config_hash=cfg.hash(),
        shape_file=shape_record(cfg),
        machine=machine_info(),
        rows=rows,
        smallest_feasible_lambda_p=min(feasible) if feasible else None,
        plant=cfg.simulation.plant,
    )
    write_summary(out / "sweep.json", summary)
    t = np.arange(cfg.mpc.n_steps + 1) * cfg.mpc.dt
    figures.save(figures.lambda_sensitivity(t, err_x, tube_x, "x (m)"), out / "fig15_lambda_x.png")
    figures.save(figures.lambda_sensitivity(t, err_phi, tube_phi, "phi_x (rad)"), out / "fig16_lambda_phi.png")
    return summary
