"""Resumable, seeded campaigns of independent runs (Monte Carlo) on local processes or Dask.

Every run i gets its own seed from the master seed (``numpy.random.SeedSequence(master_seed,
spawn_key=(i,))``), so a run's result does not depend on how many runs there are, on the worker
that ran it or on the order they finished. Each result is written by the coordinating process as
soon as it arrives (``runs/run_00007.json``, atomically: written to a temporary file, then renamed),
so an interrupted campaign loses only the runs in flight and a rerun does only what is missing. A
failed run is recorded with its error and traceback (``runs/run_00007.failed.json``) and is rerun
with ``retry_failed=True`` or alone with ``only=[7]``.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import multiprocessing
import os
import tempfile
import traceback
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["CampaignResult", "run_campaign", "run_seed"]

RunFunction = Callable[[int, int], dict[str, Any]]


def run_seed(master_seed: int, index: int) -> int:
    """The 63-bit seed of run ``index`` derived from ``master_seed``."""
    ss = np.random.SeedSequence(int(master_seed), spawn_key=(int(index),))
    return int(ss.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


@dataclass
class CampaignResult:
    """Results of a campaign: successful runs by index, failures by index (error text)."""

    out_dir: Path
    results: dict[int, dict[str, Any]] = field(default_factory=dict)
    failures: dict[int, str] = field(default_factory=dict)
    executed: list[int] = field(default_factory=list)  # the runs this call actually ran


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(payload, f, indent=1, sort_keys=True)
    os.replace(tmp, path)


def _execute(run_fn: RunFunction, index: int, seed: int) -> dict[str, Any]:
    try:
        return {"index": index, "seed": seed, "ok": True, "result": run_fn(index, seed)}
    except Exception as exc:  # recorded with the run, never lost
        return {
            "index": index,
            "seed": seed,
            "ok": False,
            "error": f"{type(exc).__name__}: {exc}",
            "traceback": traceback.format_exc(),
        }


def _manifest_check(out_dir: Path, manifest: dict[str, Any]) -> None:
    path = out_dir / "campaign.json"
    if path.exists():
        old = json.loads(path.read_text(encoding="utf-8"))
        for key in ("master_seed", "config_hash"):
            if old.get(key) != manifest.get(key):
                raise ValueError(
                    f"{path}: existing campaign has {key}={old.get(key)!r}, this call {manifest.get(key)!r}; "
                    "use another output folder"
                )
        manifest = {**old, "n_runs": max(int(old.get("n_runs", 0)), int(manifest["n_runs"]))}
    _write_json(path, manifest)


def run_campaign(
    run_fn: RunFunction,
    n_runs: int,
    out_dir: str | Path,
    master_seed: int,
    *,
    config_hash: str = "",
    shape_file: dict[str, Any] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_failed: bool = False,
    only: Iterable[int] | None = None,
    progress: bool = True,
) -> CampaignResult:
    """Runs ``run_fn(index, seed) -> dict`` for every missing run index in ``range(n_runs)``.

    ``run_fn`` must be picklable (a module-level function or a ``functools.partial`` of one) and its
    result JSON-serialisable. ``workers`` local processes (default: CPU count; 1 runs in this process);
    with ``scheduler`` (a Dask scheduler address such as ``tcp://127.0.0.1:8786``) the runs go to that
    Dask cluster instead. ``config_hash`` guards the folder against mixing campaigns; ``shape_file``
    (the pinned shape's file and sha256, :func:`tubempc.results.pinning.shape_record`) is kept in its
    ``campaign.json`` for re-flights to check.
    """
    if n_runs < 1:
        raise ValueError(f"n_runs must be >= 1, got {n_runs}")
    out = Path(out_dir)
    runs_dir = out / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    manifest: dict[str, Any] = {"master_seed": int(master_seed), "config_hash": config_hash, "n_runs": int(n_runs)}
    if shape_file is not None:
        manifest["shape_file"] = shape_file
    _manifest_check(out, manifest)

    wanted = sorted(set(range(n_runs)) if only is None else {int(i) for i in only})
    bad = [i for i in wanted if not 0 <= i < n_runs]
    if bad:
        raise ValueError(f"run indices out of range(0, {n_runs}): {bad}")

    def ok_path(i: int) -> Path:
        return runs_dir / f"run_{i:05d}.json"

    def failed_path(i: int) -> Path:
        return runs_dir / f"run_{i:05d}.failed.json"

    todo = [
        i for i in wanted if not ok_path(i).exists() and (retry_failed or only is not None or not failed_path(i).exists())
    ]
    campaign = CampaignResult(out_dir=out)

    def record(rec: dict[str, Any]) -> None:
        i = int(rec["index"])
        campaign.executed.append(i)
        if rec["ok"]:
            _write_json(ok_path(i), rec)
            failed_path(i).unlink(missing_ok=True)
        else:
            _write_json(failed_path(i), rec)

    bar = None
    if progress and todo:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc="runs", unit="run")
    try:
        tasks = [(i, run_seed(master_seed, i)) for i in todo]
        if scheduler:
            from distributed import Client, as_completed

            with Client(scheduler) as client:
                futures = [client.submit(_execute, run_fn, i, s, pure=False) for i, s in tasks]
                for fut in as_completed(futures):
                    record(fut.result())
                    if bar is not None:
                        bar.update()
        elif (workers or os.cpu_count() or 1) == 1 or len(tasks) <= 1:
            for i, s in tasks:
                record(_execute(run_fn, i, s))
                if bar is not None:
                    bar.update()
        else:
            ctx = multiprocessing.get_context("spawn")
            with cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
                pending = {pool.submit(_execute, run_fn, i, s): (i, s) for i, s in tasks}
                for fut in cf.as_completed(pending):
                    i, s = pending[fut]
                    try:
                        rec = fut.result()
                    except Exception as exc:  # a worker died (e.g. killed): the run is recorded as failed
                        rec = {
                            "index": i,
                            "seed": s,
                            "ok": False,
                            "error": f"{type(exc).__name__}: {exc}",
                            "traceback": traceback.format_exc(),
                        }
                    record(rec)
                    if bar is not None:
                        bar.update()
    finally:
        if bar is not None:
            bar.close()

    for i in range(n_runs):
        if ok_path(i).exists():
            campaign.results[i] = json.loads(ok_path(i).read_text(encoding="utf-8"))["result"]
        elif failed_path(i).exists():
            campaign.failures[i] = json.loads(failed_path(i).read_text(encoding="utf-8"))["error"]
    return campaign
