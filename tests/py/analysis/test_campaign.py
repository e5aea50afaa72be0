"""Resumable seeded campaigns: interruption and resume, failures, batches on local processes and Dask, all
into the columnar store with the same contents."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pytest

from tubempc.analysis.campaign import default_batch_size, run_campaign, run_seed
from tubempc.results.campaign_store import CampaignStore, RunOutput

HERE = Path(__file__).resolve().parent


def toy_run(index: int, seed: int, delay: float = 0.0) -> RunOutput:
    """A stand-in for one closed-loop simulation: a deterministic function of the seed, with nested
    results, a matrix of dispersions, a status that only some runs take and per-step arrays of two
    lengths."""
    time.sleep(delay)
    rng = np.random.default_rng(seed)
    T = 4 + index % 3
    result = {
        "a": {"J": float(rng.normal()), "statuses": {"solved": T, **({"fallback": 1} if index % 2 else {})}},
        "applied": {"S": rng.normal(size=(2, 2)), "max_steps": None, "model": "toy", "draws": rng.uniform(size=3)},
    }
    steps = {"a": {"error": rng.normal(size=(T, 3)).astype(np.float32), "nees": rng.normal(size=T + 1)}}
    return RunOutput(result, steps)


def interrupted_run(index: int, seed: int, at: int, flag: str) -> RunOutput:
    """toy_run, but run ``at`` raises KeyboardInterrupt (Ctrl-C) until ``flag`` exists."""
    if index == at and not Path(flag).exists():
        raise KeyboardInterrupt
    return toy_run(index, seed)


def flaky_run(index: int, seed: int, flag: str) -> RunOutput:
    if index == 2 and not Path(flag).exists():
        raise RuntimeError("simulated divergence")
    return toy_run(index, seed)


def contents(folder: Path) -> tuple[pa.Table, pa.Table]:
    """The store's two tables as plain pyarrow reads them (no tubempc), sorted, without the run times
    (the machine's)."""
    import pyarrow.parquet as pq

    runs = pq.read_table(folder / "store" / "runs").replace_schema_metadata(None)
    runs = runs.drop_columns([c for c in runs.column_names if c.endswith("run_time_s")]).sort_by("index")
    runs = runs.select(sorted(runs.column_names))
    steps = pq.read_table(folder / "store" / "steps").replace_schema_metadata(None)
    steps = steps.sort_by([("index", "ascending"), ("group", "ascending"), ("step", "ascending")])
    return runs, steps.select(sorted(steps.column_names))


def test_seed_of_a_run_depends_only_on_master_seed_and_index() -> None:
    assert run_seed(7, 3) == run_seed(7, 3)
    assert len({run_seed(7, i) for i in range(100)}) == 100
    assert run_seed(7, 3) != run_seed(8, 3)


def test_default_batches_make_tasks_cheap_and_keep_the_workers_busy() -> None:
    assert default_batch_size(1, 2) == 1
    assert default_batch_size(100, 2) == 7  # 15 tasks for 2 workers
    assert default_batch_size(100_000, 2) == 64  # 1563 tasks: 1.6 s of Dask overhead over the campaign
    assert default_batch_size(100_000, 64) == 64 and default_batch_size(1000, 64) == 2


def test_one_worker_two_workers_any_batch_and_dask_store_the_same(tmp_path: Path) -> None:
    serial = run_campaign(toy_run, 9, tmp_path / "s", 5, workers=1, progress=False)
    assert serial.completed == list(range(9)) and not serial.failures
    run_campaign(toy_run, 9, tmp_path / "p1", 5, workers=2, batch_size=1, progress=False)
    run_campaign(toy_run, 9, tmp_path / "p4", 5, workers=2, batch_size=4, progress=False)
    want = contents(tmp_path / "s")
    assert want[0].num_rows == 9 and want[1].num_rows == sum(5 + i % 3 for i in range(9))
    for name in ("p1", "p4"):
        got = contents(tmp_path / name)
        assert got[0].equals(want[0]) and got[1].equals(want[1]), name
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        run_campaign(toy_run, 9, tmp_path / "d", 5, scheduler=cluster.scheduler_address, batch_size=2, progress=False)
    got = contents(tmp_path / "d")
    assert got[0].equals(want[0]) and got[1].equals(want[1])


def test_an_interrupted_campaign_resumes_to_the_same_store(tmp_path: Path) -> None:
    """Ctrl-C at run 4 (a KeyboardInterrupt out of the run): the runs finished before it are stored, the
    resumed campaign flies only the rest and the store equals an uninterrupted campaign's."""
    flag = tmp_path / "go"
    fn = functools.partial(interrupted_run, at=4, flag=str(flag))
    out = tmp_path / "c"
    with pytest.raises(KeyboardInterrupt):
        run_campaign(fn, 8, out, 11, workers=1, progress=False, flush_seconds=3600.0)
    before = CampaignStore(out)
    assert before.indices("ok") == [0, 1, 2, 3]  # written on the way out, though not yet flushed
    stored = {i: before.row(i) for i in range(4)}
    flag.touch()
    resumed = run_campaign(fn, 8, out, 11, workers=1, progress=False)
    assert resumed.executed == [4, 5, 6, 7]
    after = CampaignStore(out)
    assert all(after.row(i) == stored[i] for i in range(4))  # finished runs untouched (run times included)
    run_campaign(toy_run, 8, tmp_path / "fresh", 11, workers=2, progress=False)
    got, want = contents(out), contents(tmp_path / "fresh")
    assert got[0].equals(want[0]) and got[1].equals(want[1])


def test_a_killed_campaign_loses_only_runs_in_flight_and_resumes(tmp_path: Path) -> None:
    out = tmp_path / "killed"
    script = textwrap.dedent(f"""
        import functools, sys
        sys.path.insert(0, {str(HERE)!r})
        from test_campaign import toy_run
        from tubempc.analysis.campaign import run_campaign
        run_campaign(functools.partial(toy_run, delay=0.4), 8, {str(out)!r}, 11, workers=1, progress=False,
                     flush_seconds=0.0)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], env={**os.environ})

    def stored() -> int:
        try:
            return len(CampaignStore(out).indices("ok"))
        except (OSError, ValueError):  # a part renamed or merged away while it was being read
            return 0

    try:
        deadline = time.monotonic() + 60
        while stored() < 3:
            assert proc.poll() is None, "campaign ended before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    store = CampaignStore(out)
    done = store.indices("ok")
    assert 3 <= len(done) < 8 and done == list(range(len(done)))
    before = {i: store.row(i) for i in done}
    resumed = run_campaign(toy_run, 8, out, 11, workers=1, progress=False)
    assert sorted(resumed.executed) == sorted(set(range(8)) - set(done))
    assert all(CampaignStore(out).row(i) == before[i] for i in done)
    run_campaign(toy_run, 8, tmp_path / "fresh", 11, workers=1, progress=False)
    got, want = contents(out), contents(tmp_path / "fresh")
    assert got[0].equals(want[0]) and got[1].equals(want[1])
    assert len(list((out / "store" / "runs").iterdir())) == 1  # merged into one part at the end


def test_failed_run_is_recorded_and_rerun_alone(tmp_path: Path) -> None:
    flag = tmp_path / "fixed"
    fn = functools.partial(flaky_run, flag=str(flag))
    first = run_campaign(fn, 4, tmp_path / "c", 3, workers=1, progress=False)
    assert first.completed == [0, 1, 3] and "simulated divergence" in first.failures[2]
    row = CampaignStore(tmp_path / "c").row(2)
    assert row["status"] == "failed" and "Traceback" in str(row["traceback"]) and row["seed"] == run_seed(3, 2)
    assert row["a.J"] is None  # a failed run has no result
    assert run_campaign(fn, 4, tmp_path / "c", 3, workers=1, progress=False).executed == []
    flag.touch()
    again = run_campaign(fn, 4, tmp_path / "c", 3, only=[2], workers=1, progress=False)
    assert again.executed == [2] and not again.failures and again.completed == [0, 1, 2, 3]
    got, want = contents(tmp_path / "c"), contents(_fresh(tmp_path))
    assert got[0].equals(want[0]) and got[1].equals(want[1])


def _fresh(tmp_path: Path) -> Path:
    run_campaign(toy_run, 4, tmp_path / "fresh", 3, workers=1, progress=False)
    return tmp_path / "fresh"


def test_a_worker_that_dies_fails_its_batch_not_the_campaign(tmp_path: Path) -> None:
    camp = run_campaign(functools.partial(dying_run, at=1), 4, tmp_path, 2, workers=2, batch_size=2, progress=False)
    assert set(camp.failures) >= {0, 1} and all("BrokenProcessPool" in e for e in camp.failures.values())
    assert set(camp.completed) | set(camp.failures) == {0, 1, 2, 3}


def dying_run(index: int, seed: int, at: int) -> dict[str, Any]:
    if index == at:
        os._exit(3)  # the worker process dies
    return {"J": float(seed % 7)}


def test_folder_of_another_campaign_is_refused(tmp_path: Path) -> None:
    run_campaign(toy_run, 2, tmp_path, 1, workers=1, progress=False)
    with pytest.raises(ValueError, match="master_seed"):
        run_campaign(toy_run, 2, tmp_path, 2, workers=1, progress=False)
