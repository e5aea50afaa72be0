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
from matplotlib.figure import Figure

from ..config import Config, load_config
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
    write_summary,
)
from ..scenario.build import METHODS, Scenario, build_scenario
from ..scenario.sites import site_map, tangent_axes
from ..sim.closed_loop import simulate
from . import figures
from .campaign import CampaignResult, run_campaign
from .claims import TOUCHDOWN_GOAL
from .runner import guarantee_lost, run_summary

__all__ = [
    "MONTECARLO_METRICS",
    "Reflight",
    "dispersion_figure",
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


#: The metrics a Monte Carlo run keeps per method (the fields of its record's "result",
#: :class:`tubempc.results.summaries.CampaignMethodResult`; run_time_s is the machine's).
MONTECARLO_METRICS = tuple(f.name for f in dataclasses.fields(CampaignMethodResult))


def _fly_montecarlo_run(
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


def _run_arrays(records: dict[str, RunRecord]) -> dict[str, np.ndarray]:
    """A campaign run's arrays (runs/run_<i>.npz): per method the error x - z (T, 12) and the tube
    half-widths sqrt(diag Pe) (T, 12), float32."""
    arrays: dict[str, np.ndarray] = {}
    for m, rec in records.items():
        arrays[f"{m}_error"] = (rec.x[:-1] - rec.z).astype(np.float32)
        arrays[f"{m}_half_width"] = np.sqrt(
            np.concatenate([np.diagonal(rec.Pe_p, axis1=1, axis2=2), np.diagonal(rec.Pe_r, axis1=1, axis2=2)], axis=1)
        ).astype(np.float32)
        if rec.navigation is not None:  # flown on the estimate: the navigation's per-step record
            arrays.update({f"{m}_{k}": np.asarray(v, dtype=np.float32) for k, v in rec.navigation.campaign_arrays().items()})
            arrays[f"{m}_nav_touchdown_error"] = rec.x[-1] - rec.zbar[-1]  # x_T - x_f (12), the dispersion
    return arrays


def _montecarlo_run(
    cfg: Config,
    cache_dir: str,
    runs_dir: str,
    methods: tuple[str, ...],
    max_steps: int | None,
    tube_threads: int,
    index: int,
    seed: int,
) -> dict[str, Any]:
    """One Monte Carlo run: every method with the same disturbance seed. Metrics and the dispersions
    applied go in the result; the error trajectories x - z and tube half-widths in runs/run_<i>.npz
    (for the envelopes)."""
    out, records = _fly_montecarlo_run(cfg, _scenario(cfg, cache_dir), methods, max_steps, tube_threads, seed)
    arrays = _run_arrays(records)
    path = Path(runs_dir) / f"run_{index:05d}.npz"
    tmp = path.with_name(f".{path.name}.tmp.npz")
    np.savez_compressed(tmp, allow_pickle=False, **arrays)
    os.replace(tmp, path)
    return out.to_json()


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
    comparison: every metric (but run_time_s) and the applied dispersions against the record's, with
    ``equal`` True when all are the same to the bit."""
    path = campaign_dir / "runs" / f"run_{index:05d}.json"
    if not path.exists():
        raise ValueError(f"{path}: no such run in the campaign (see {campaign_dir / 'runs'})")
    record = json.loads(path.read_text(encoding="utf-8"))
    if not record.get("ok"):
        raise ValueError(f"{path}: the run failed in the campaign: {record.get('error')}")
    result = CampaignRunResult.from_json(record["result"], f"{path}: result")
    if result.applied is None:
        raise ValueError(f"{path}: written before runs recorded their dispersions; rerun the campaign")
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
    flown, records = _fly_montecarlo_run(cfg, scn, methods, result.applied["max_steps"], 1, int(record["seed"]))
    out.mkdir(parents=True, exist_ok=True)
    for m, rec in records.items():
        save_record(out / f"{m}.h5", rec, config=cfg.to_dict(), metadata=flown.methods[m].to_json())
    # JSON round trip: the record's numbers were read from JSON (floats survive it exactly).
    again = CampaignRunResult.from_json(json.loads(json.dumps(flown.to_json())))
    for m in methods:
        now, then = again.methods[m].to_json(), record["result"][m]
        differences += [f"{m}.{k}" for k in MONTECARLO_METRICS if k != "run_time_s" and k in then and now.get(k) != then[k]]
    differences += ["applied"] if again.applied != result.applied else []
    differences += _array_differences(campaign_dir / "runs" / f"run_{index:05d}.npz", _run_arrays(records))
    comparison = Reflight(
        campaign=str(campaign_dir),
        index=index,
        seed=int(record["seed"]),
        methods={m: {"J_p": again.methods[m].J_p, "J_r": again.methods[m].J_r} for m in methods},
        guarantee_lost={m: guarantee_lost(again.methods[m]) for m in methods},
        differences=differences,
        machine=machine_info(),
    )
    (out / "refly.json").write_text(json.dumps(comparison.to_json(), indent=1, sort_keys=True))
    return comparison


def _array_differences(path: Path, arrays: dict[str, np.ndarray]) -> list[str]:
    """The arrays of a campaign run's file that are not those of its re-flight, to the bit (their
    names; the file itself when it is missing or unreadable)."""
    if not path.exists():
        return [f"{path.name} (missing)"]
    try:
        with np.load(path, allow_pickle=False) as stored:
            names = set(stored.files)
            out = [f"{path.name}:{k}" for k in sorted(names - set(arrays))]
            for k, a in sorted(arrays.items()):
                if k not in names:
                    out.append(f"{path.name}:{k} (missing)")
                    continue
                b = stored[k]
                if b.dtype != a.dtype or b.shape != a.shape or b.tobytes() != a.tobytes():
                    out.append(f"{path.name}:{k}")
    except (OSError, ValueError) as exc:
        return [f"{path.name} (unreadable: {exc})"]
    return out


def montecarlo_summary(
    campaign: CampaignResult,
    methods: tuple[str, ...],
    *,
    master_seed: int,
    config_hash: str,
    wall_time_s: float,
    workers: int | None = None,
    scheduler: str | None = None,
    plant: str | None = None,
) -> MonteCarloSummary:
    """Table 4 (mean and 3 sigma of J_p and J_r per method) and the runs that ever left the tube; for runs
    flown on navigation, the fraction whose average NEES lies inside its bounds (each run's result keeps
    its :class:`tubempc.results.summaries.NavigationSummary`: the touchdown estimation error, the NEES, ...)."""
    where = campaign.out_dir / "runs"
    results = [
        CampaignRunResult.from_json(r, f"{where}/run_{i:05d}.json: result") for i, r in sorted(campaign.results.items())
    ]
    per_method: dict[str, MonteCarloMethodSummary] = {}
    for m in methods:
        rows = [r.methods[m] for r in results]
        if not rows:
            continue
        jp = np.array([r.J_p for r in rows])
        jr = np.array([r.J_r for r in rows])
        exc = np.array([max(r.max_tube_excursion.translation, r.max_tube_excursion.rotation) for r in rows])
        nees = [r.navigation.nees for r in rows if r.navigation is not None and r.navigation.nees is not None]
        per_method[m] = MonteCarloMethodSummary(
            J_p=MeanSpread(mean=float(jp.mean()), three_sigma=float(3 * jp.std(ddof=1)) if jp.size > 1 else 0.0),
            J_r=MeanSpread(mean=float(jr.mean()), three_sigma=float(3 * jr.std(ddof=1)) if jr.size > 1 else 0.0),
            runs_outside_tube=int(np.sum(exc > 1.0)),
            max_tube_excursion=float(exc.max()),
            runs_with_cone_violation=int(sum(r.constraint_violations.steps > 0 for r in rows)),
            terminal_position_error_max_m=float(max(r.terminal_error.position for r in rows)),
            runs_inside_body=int(sum((r.states_inside_body or 0) > 0 for r in rows)),
            runs_guarantee_lost=int(sum(bool(guarantee_lost(r)) for r in rows)),
            nees_inside_fraction=float(np.mean([t.inside for t in nees])) if nees else None,
        )
    reduction = None
    if {"tbmpc", "ffa"} <= set(per_method):
        reduction = 100.0 * (1.0 - per_method["ffa"].J_p.mean / per_method["tbmpc"].J_p.mean)
    return MonteCarloSummary(
        runs=len(campaign.results),
        failed_runs=sorted(campaign.failures),
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
    )


def montecarlo(
    cfg: Config,
    runs: int,
    out: Path,
    *,
    master_seed: int = 0,
    workers: int | None = None,
    scheduler: str | None = None,
    methods: tuple[str, ...] = METHODS,
    retry_failed: bool = False,
    only: list[int] | None = None,
    progress: bool = True,
    max_steps: int | None = None,
) -> MonteCarloSummary:
    """Runs (or resumes) a campaign into ``out`` and writes ``out/summary.json`` and the envelope figures.

    ``max_steps`` cuts every run short (quick checks); None runs the whole mission."""
    out.mkdir(parents=True, exist_ok=True)
    cfg = pin_config(cfg, out)  # the folder keeps its shape file: it re-flies wherever it is copied
    cache = out / "cache"
    scn = build_scenario(cfg, cache_dir=cache)  # the reference once, before the workers read it from the cache
    cfg.save(out / "config.toml")
    runs_dir = out / "runs"
    runs_dir.mkdir(exist_ok=True)
    # Several runs at once already occupy the cores: then each run designs its two tubes sequentially.
    parallel_runs = scheduler is not None or (workers or os.cpu_count() or 1) > 1
    fn = functools.partial(
        _montecarlo_run, cfg, str(cache), str(runs_dir), tuple(methods), max_steps, 1 if parallel_runs else 2
    )
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
        retry_failed=retry_failed,
        only=only,
        progress=progress,
    )
    summary = montecarlo_summary(
        camp,
        tuple(methods),
        master_seed=master_seed,
        config_hash=cfg.hash(),
        wall_time_s=time.perf_counter() - t0,
        workers=workers,
        scheduler=scheduler,
        plant=cfg.simulation.plant,
    )
    write_summary(out / "summary.json", summary)
    _envelope_figures(cfg, camp, out, tuple(methods))
    for m in methods:  # a campaign flown on navigation to a site: the touchdown dispersion on the site map
        fig = dispersion_figure(scn, out, m)
        if fig is not None:
            figures.save(fig, out / f"fig21_touchdown_{m}.png")
    return summary


def touchdown_offsets(scn: Scenario, out: Path, method: str) -> np.ndarray:
    """The touchdown offsets of ``method``'s runs in the campaign folder ``out`` (those that kept
    ``<method>_nav_touchdown_error``, x_T - x_f, in runs/run_<i>.npz: runs flown on navigation):
    (n, 2) (east, north) (m) in the site's tangent plane (:func:`tubempc.scenario.sites.tangent_axes`),
    the position error taken from L to A at t_f. Empty without a site or such runs."""
    if scn.site is None:
        return np.zeros((0, 2))
    C_AL = np.asarray(scn.model.C_AL(scn.config.mpc.t_f))
    east, north = tangent_axes(scn.site.normal_A)
    offsets = []
    for npz in sorted((out / "runs").glob("run_*.npz")):
        with np.load(npz) as d:
            key = f"{method}_nav_touchdown_error"
            if key in d.files:
                dr_A = C_AL @ d[key][:3].astype(float)
                offsets.append([dr_A @ east, dr_A @ north])
    return np.array(offsets).reshape(-1, 2)


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


def _envelope_figures(cfg: Config, camp: CampaignResult, out: Path, methods: tuple[str, ...]) -> None:
    t = np.arange(cfg.mpc.n_steps + 1) * cfg.mpc.dt
    for m in methods:
        errs: list[np.ndarray] = []
        widths: list[np.ndarray] = []
        for i in sorted(camp.results):
            p = out / "runs" / f"run_{i:05d}.npz"
            if p.exists():
                with np.load(p) as d:
                    errs.append(d[f"{m}_error"].astype(float))
                    widths.append(d[f"{m}_half_width"].astype(float))
        if not errs:
            continue
        hw = np.max(np.stack(widths), axis=0)
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
                    t,
                    [e[:, sl] for e in errs],
                    hw[:, sl],
                    labels,
                    f"{m}: {len(errs)} Monte Carlo runs, x - z against the tube",
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
