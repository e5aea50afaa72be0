"""Resumable seeded campaigns: interruption and resume, failures, local processes and Dask."""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc.analysis.campaign import run_campaign, run_seed

HERE = Path(__file__).resolve().parent


def toy_run(index: int, seed: int, delay: float = 0.0) -> dict[str, Any]:
    """A stand-in for one closed-loop simulation: a deterministic function of the seed."""
    time.sleep(delay)
    rng = np.random.default_rng(seed)
    return {"index": index, "J": float(rng.normal()), "draws": rng.uniform(size=3).tolist()}


def flaky_run(index: int, seed: int, flag: str) -> dict[str, Any]:
    if index == 2 and not Path(flag).exists():
        raise RuntimeError("simulated divergence")
    return toy_run(index, seed)


def _contents(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in sorted((folder / "runs").glob("run_*.json"))}


def test_seed_of_a_run_depends_only_on_master_seed_and_index() -> None:
    assert run_seed(7, 3) == run_seed(7, 3)
    assert len({run_seed(7, i) for i in range(100)}) == 100
    assert run_seed(7, 3) != run_seed(8, 3)


def test_killed_campaign_resumes_with_identical_results(tmp_path: Path) -> None:
    out = tmp_path / "killed"
    script = textwrap.dedent(f"""
        import functools, sys
        sys.path.insert(0, {str(HERE)!r})
        from test_campaign import toy_run
        from tubempc.analysis.campaign import run_campaign
        run_campaign(functools.partial(toy_run, delay=0.4), 8, {str(out)!r}, 11, workers=1, progress=False)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], env={**os.environ})
    try:
        deadline = time.monotonic() + 60
        while len(list((out / "runs").glob("run_*.json"))) < 3:
            assert proc.poll() is None, "campaign ended before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    before = _contents(out)
    assert 3 <= len(before) < 8

    resumed = run_campaign(toy_run, 8, out, 11, workers=1, progress=False)
    done_before = {int(name[4:9]) for name in before}
    assert sorted(resumed.executed) == sorted(set(range(8)) - done_before)
    after = _contents(out)
    assert all(after[name] == text for name, text in before.items())  # finished runs untouched

    fresh = run_campaign(toy_run, 8, tmp_path / "fresh", 11, workers=1, progress=False)
    assert fresh.results == resumed.results


def test_failed_run_is_recorded_and_rerun_alone(tmp_path: Path) -> None:
    flag = tmp_path / "fixed"
    fn = functools.partial(flaky_run, flag=str(flag))
    first = run_campaign(fn, 4, tmp_path / "c", 3, workers=1, progress=False)
    assert set(first.results) == {0, 1, 3} and "simulated divergence" in first.failures[2]
    record = json.loads((tmp_path / "c" / "runs" / "run_00002.failed.json").read_text())
    assert "Traceback" in record["traceback"] and record["seed"] == run_seed(3, 2)
    assert run_campaign(fn, 4, tmp_path / "c", 3, workers=1, progress=False).executed == []
    flag.touch()
    again = run_campaign(fn, 4, tmp_path / "c", 3, only=[2], workers=1, progress=False)
    assert again.executed == [2] and not again.failures and len(again.results) == 4


def test_folder_of_another_campaign_is_refused(tmp_path: Path) -> None:
    run_campaign(toy_run, 2, tmp_path, 1, workers=1, progress=False)
    with pytest.raises(ValueError, match="master_seed"):
        run_campaign(toy_run, 2, tmp_path, 2, workers=1, progress=False)


def test_local_processes_give_the_serial_results(tmp_path: Path) -> None:
    serial = run_campaign(toy_run, 6, tmp_path / "s", 5, workers=1, progress=False)
    parallel = run_campaign(toy_run, 6, tmp_path / "p", 5, workers=2, progress=False)
    assert parallel.results == serial.results


def test_dask_local_cluster_gives_the_serial_results(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    serial = run_campaign(toy_run, 4, tmp_path / "s", 9, workers=1, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        dask = run_campaign(toy_run, 4, tmp_path / "d", 9, scheduler=cluster.scheduler_address, progress=False)
    assert dask.results == serial.results
