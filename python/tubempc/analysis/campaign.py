"""Resumable, seeded campaigns of independent runs (Monte Carlo) on local processes or Dask.

Every run i gets its own seed from the master seed (``numpy.random.SeedSequence(master_seed,
spawn_key=(i,))``), so a run's result does not depend on how many runs there are, on the worker
that ran it, on how runs were batched or on the order they finished. The coordinating process is the
store's one writer (:class:`tubempc.results.campaign_store.CampaignStoreWriter`): finished runs are
appended to the campaign's Parquet store in part files written atomically (a few seconds' worth at a
time, and whatever is finished when the campaign stops on an error or Ctrl-C), so an interrupted
campaign loses only the runs in flight and a rerun does only what is missing. A failed run is stored
with its error and traceback (status "failed") and is rerun with ``retry_failed=True`` or alone with
``only=[7]``. Runs go to workers in batches (``batch_size`` runs per task): a task then costs
Dask's or the process pool's overhead (about 1 ms) once per batch.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import math
import multiprocessing
import os
import tempfile
import time
import traceback
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..results.campaign_store import STORE_FORMAT, CampaignStore, CampaignStoreWriter, RunOutput, RunRow

__all__ = ["CampaignResult", "default_batch_size", "run_campaign", "run_seed"]

RunFunction = Callable[[int, int], "RunOutput | Mapping[str, Any]"]

#: Largest default number of runs per task (:func:`default_batch_size`).
MAX_BATCH = 64
#: Tasks per worker the default batch size aims at (the tail's imbalance is at most one task).
TASKS_PER_WORKER = 8


def run_seed(master_seed: int, index: int) -> int:
    """The 63-bit seed of run ``index`` derived from ``master_seed``."""
    ss = np.random.SeedSequence(int(master_seed), spawn_key=(int(index),))
    return int(ss.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


def default_batch_size(runs: int, workers: int) -> int:
    """Runs per task: about :data:`TASKS_PER_WORKER` tasks per worker, at most :data:`MAX_BATCH` runs
    (docs/decisions.md "The campaign store")."""
    return max(1, min(MAX_BATCH, math.ceil(runs / (TASKS_PER_WORKER * max(1, workers)))))


@dataclass
class CampaignResult:
    """A campaign's runs after a call: the indices stored as done, the failures by index (error text),
    and the runs this call executed; :attr:`store` reads them."""

    out_dir: Path
    completed: list[int] = field(default_factory=list)
    failures: dict[int, str] = field(default_factory=dict)
    executed: list[int] = field(default_factory=list)  # the runs this call actually ran

    @property
    def store(self) -> CampaignStore:
        """The campaign's store, as it is on disk now."""
        return CampaignStore(self.out_dir)


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(payload, f, indent=1, sort_keys=True)
    os.replace(tmp, path)


def _execute(run_fn: RunFunction, index: int, seed: int) -> RunRow:
    t0 = time.perf_counter()
    try:
        out = run_fn(index, seed)
        output = out if isinstance(out, RunOutput) else RunOutput(dict(out))
        return RunRow(index, seed, True, time.perf_counter() - t0, output)
    except Exception as exc:  # stored with the run, never lost
        return RunRow(
            index, seed, False, time.perf_counter() - t0, None, f"{type(exc).__name__}: {exc}", traceback.format_exc()
        )


def _execute_batch(run_fn: RunFunction, tasks: list[tuple[int, int]]) -> list[RunRow]:
    """One task: the runs of a batch in order (a worker's exception other than a run's own, such as
    KeyboardInterrupt, loses the batch: its runs were in flight)."""
    return [_execute(run_fn, i, s) for i, s in tasks]


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
        manifest = {**old, "n_runs": max(int(old.get("n_runs", 0)), int(manifest["n_runs"])), "store": STORE_FORMAT}
    _write_json(path, manifest)


def _failed(index: int, seed: int, exc: BaseException) -> RunRow:
    """A run whose worker died (e.g. killed): stored as failed."""
    tb = "".join(traceback.format_exception(exc))
    return RunRow(index, seed, False, math.nan, None, f"{type(exc).__name__}: {exc}", tb)


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
    batch_size: int | None = None,
    retry_failed: bool = False,
    only: Iterable[int] | None = None,
    progress: bool = True,
    flush_seconds: float = 10.0,
) -> CampaignResult:
    """Runs ``run_fn(index, seed)`` for every missing run index in ``range(n_runs)`` into the store of
    ``out_dir``.

    ``run_fn`` returns a :class:`tubempc.results.campaign_store.RunOutput` (its result, the runs
    table's columns, and per-step arrays) or just the result (a mapping); it must be picklable (a
    module-level function or a ``functools.partial`` of one). ``workers`` local processes (default:
    CPU count; 1 runs in this process, one run at a time); with ``scheduler`` (a Dask scheduler
    address such as ``tcp://127.0.0.1:8786``) the runs go to that Dask cluster instead. ``batch_size``
    runs go to a worker per task (default :func:`default_batch_size`). Finished runs are written at
    least every ``flush_seconds`` (0: each at once). ``config_hash`` guards the folder against mixing
    campaigns; ``shape_file`` (the pinned shape's file and sha256,
    :func:`tubempc.results.pinning.shape_record`) is kept in its ``campaign.json`` for re-flights to
    check."""
    if n_runs < 1:
        raise ValueError(f"n_runs must be >= 1, got {n_runs}")
    if batch_size is not None and batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    store = CampaignStore(out)  # a folder of the layout before the store is refused here, with the converter
    manifest: dict[str, Any] = {
        "master_seed": int(master_seed),
        "config_hash": config_hash,
        "n_runs": int(n_runs),
        "store": STORE_FORMAT,
    }
    if shape_file is not None:
        manifest["shape_file"] = shape_file
    _manifest_check(out, manifest)

    wanted = sorted(set(range(n_runs)) if only is None else {int(i) for i in only})
    bad = [i for i in wanted if not 0 <= i < n_runs]
    if bad:
        raise ValueError(f"run indices out of range(0, {n_runs}): {bad}")
    done = set(store.indices("ok"))
    failed = set(store.indices("failed"))
    todo = [i for i in wanted if i not in done and (retry_failed or only is not None or i not in failed)]
    campaign = CampaignResult(out_dir=out)

    bar = None
    if progress and todo:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc="runs", unit="run")
    tasks = [(i, run_seed(master_seed, i)) for i in todo]
    with CampaignStoreWriter(out, flush_seconds=flush_seconds) as writer:

        def record(rows: list[RunRow]) -> None:
            for row in rows:
                campaign.executed.append(row.index)
                try:
                    writer.add(row)
                except ValueError as exc:  # a result the store cannot keep: the run is stored as failed
                    writer.add(_failed(row.index, row.seed, exc))
            if bar is not None:
                bar.update(len(rows))

        try:
            if scheduler:
                from distributed import Client, as_completed

                with Client(scheduler) as client:
                    n_workers = sum(client.nthreads().values()) or 1
                    batches = _batches(tasks, batch_size or default_batch_size(len(tasks), n_workers))
                    futures = {client.submit(_execute_batch, run_fn, b, pure=False): b for b in batches}
                    try:
                        for fut in as_completed(futures):
                            record(fut.result())
                    finally:
                        client.cancel(list(futures))
            elif (workers or os.cpu_count() or 1) == 1 or len(tasks) <= 1:
                for i, s in tasks:
                    record([_execute(run_fn, i, s)])
            else:
                n_workers = workers or os.cpu_count() or 1
                batches = _batches(tasks, batch_size or default_batch_size(len(tasks), n_workers))
                ctx = multiprocessing.get_context("spawn")
                pool = cf.ProcessPoolExecutor(max_workers=n_workers, mp_context=ctx)
                try:
                    pending = {pool.submit(_execute_batch, run_fn, b): b for b in batches}
                    for fut in cf.as_completed(pending):
                        try:
                            rows = fut.result()
                        except Exception as exc:  # a worker died (e.g. killed): its batch is stored as failed
                            rows = [_failed(i, s, exc) for i, s in pending[fut]]
                        record(rows)
                finally:
                    pool.shutdown(wait=True, cancel_futures=True)
        finally:
            if bar is not None:
                bar.close()

    stored = CampaignStore(out)
    campaign.completed = [i for i in stored.indices("ok") if i < n_runs]
    campaign.failures = {i: e for i, e in stored.failures().items() if i < n_runs}
    return campaign


def _batches(tasks: list[tuple[int, int]], size: int) -> list[list[tuple[int, int]]]:
    return [tasks[k : k + size] for k in range(0, len(tasks), size)]
