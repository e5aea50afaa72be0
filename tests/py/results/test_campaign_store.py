"""The campaign store: flattening, atomic parts and their merges, the winner of a run written twice, reading
with pandas alone (and xarray), and the conversion of the layout before it."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from tubempc.results.campaign_store import (
    CampaignStore,
    CampaignStoreWriter,
    LegacyCampaignError,
    RunOutput,
    RunRow,
    differing_columns,
    differing_steps,
    flatten,
    unflatten,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "analysis"))
from test_campaign import contents, toy_run


def _row(i: int, ok: bool = True, **result: object) -> RunRow:
    out = toy_run(i, 1000 + i)
    if result:
        out = RunOutput({**out.result, **result}, out.steps)
    if not ok:
        return RunRow(i, 1000 + i, False, 0.5, None, "RuntimeError: boom", "Traceback ...")
    return RunRow(i, 1000 + i, True, 0.5, out)


def test_flatten_names_every_scalar_and_unflatten_inverts_it() -> None:
    value = {"a": {"J": 1.5, "n": 3, "ok": True, "s": "x", "none": None}, "m": [[1.0, 2.0], [3.0, 4.0]], "v": np.arange(3)}
    flat = flatten(value)
    assert flat == {
        "a.J": 1.5,
        "a.n": 3,
        "a.ok": True,
        "a.s": "x",
        "a.none": None,
        "m[0][0]": 1.0,
        "m[0][1]": 2.0,
        "m[1][0]": 3.0,
        "m[1][1]": 4.0,
        "v[0]": 0,
        "v[1]": 1,
        "v[2]": 2,
    }
    back = unflatten(flat)
    assert back == {"a": {"J": 1.5, "n": 3, "ok": True, "s": "x"}, "m": [[1.0, 2.0], [3.0, 4.0]], "v": [0, 1, 2]}
    with pytest.raises(ValueError, match=r"key 'b\.c'"):
        flatten({"a": {"b.c": 1}})
    with pytest.raises(ValueError, match="outside int64"):
        flatten({"seed": 2**63})
    with pytest.raises(ValueError, match=r"'a\.f'"):
        flatten({"a": {"f": object()}})


def test_a_run_reads_back_to_the_bit(tmp_path: Path) -> None:
    with CampaignStoreWriter(tmp_path) as w:
        for i in range(5):
            w.add(_row(i))
    store = CampaignStore(tmp_path)
    for i in range(5):
        out = toy_run(i, 1000 + i)
        assert differing_columns(store.row(i), flatten(out.result)) == []
        assert differing_steps(store.steps(i), out.steps) == []
        steps = store.steps(i)["a"]
        assert steps["error"].dtype == np.float32 and steps["error"].shape == (4 + i % 3, 3)
        assert steps["nees"].shape == (5 + i % 3,)
        assert store.result(i)["applied"]["S"] == out.result["applied"]["S"].tolist()
    # a changed value is named, to the last bit
    flat = flatten(toy_run(3, 1003).result)
    flat["a.J"] = float(np.nextafter(flat["a.J"], np.inf))  # type: ignore[arg-type]
    assert differing_columns(store.row(3), flat) == ["a.J"]
    steps = toy_run(3, 1003).steps
    steps["a"]["error"][1, 2] += np.float32(1e-6)
    assert differing_steps(store.steps(3), steps) == ["a.error"]


def test_parts_merge_by_level_and_a_rerun_failed_run_wins_only_when_it_succeeds(tmp_path: Path) -> None:
    w = CampaignStoreWriter(tmp_path, flush_seconds=0.0, merge_parts=3)
    for i in range(10):
        w.add(_row(i, ok=i not in (2, 7)))
        parts = list((tmp_path / "store" / "runs").glob("part-*.parquet"))
        assert len(parts) <= 4  # at most merge_parts - 1 per level
    w.add(_row(2))  # re-run: now ok
    w.add(_row(7, ok=False))  # re-run: failed again
    store = CampaignStore(tmp_path)
    assert store.indices("ok") == [0, 1, 2, 3, 4, 5, 6, 8, 9] and list(store.failures()) == [7]
    assert differing_steps(store.steps(2), toy_run(2, 1002).steps) == []
    w.close()
    assert [p.name for p in (tmp_path / "store" / "runs").iterdir()] == [
        p.name for p in (tmp_path / "store" / "steps").iterdir()
    ]
    assert len(list((tmp_path / "store" / "runs").iterdir())) == 1
    merged = CampaignStore(tmp_path)
    assert merged.indices("ok") == store.indices("ok") and merged.runs().num_rows == 10
    for i in merged.indices("ok"):
        assert differing_steps(merged.steps(i), toy_run(i, 1000 + i).steps) == []
    # an ok row is never replaced by a later failure of the same run
    with CampaignStoreWriter(tmp_path) as w2:
        w2.add(_row(3, ok=False))
    assert 3 in CampaignStore(tmp_path).indices("ok")


def test_columns_that_differ_between_parts_are_unified(tmp_path: Path) -> None:
    with CampaignStoreWriter(tmp_path, flush_seconds=0.0) as w:
        w.add(_row(0, extra={"k": 1}))
        w.add(_row(1, extra={"k": 2.5, "new": "y"}))
        w.add(_row(2))
    store = CampaignStore(tmp_path)
    assert store.row(0)["extra.k"] == 1.0 and store.row(1)["extra.k"] == 2.5 and store.row(2)["extra.k"] is None
    assert store.row(1)["extra.new"] == "y" and store.row(0)["extra.new"] is None
    assert differing_columns(store.row(0), flatten({**toy_run(0, 1000).result, "extra": {"k": 1}})) == []
    with CampaignStoreWriter(tmp_path, flush_seconds=0.0) as w:
        with pytest.raises(ValueError, match=r"'extra\.k': type double in one part, string in another"):
            w.add(_row(3, extra={"k": "text"}))  # refused before it is written: the store stays readable
        w.add(_row(4))
    assert CampaignStore(tmp_path).indices() == [0, 1, 2, 4]


def test_an_interrupted_write_leaves_no_part_that_counts(tmp_path: Path) -> None:
    with CampaignStoreWriter(tmp_path) as w:
        w.add(_row(0))
    steps_dir, runs_dir = tmp_path / "store" / "steps", tmp_path / "store" / "runs"
    (part,) = runs_dir.iterdir()
    orphan = steps_dir / "part-00000099-L0.parquet"  # a steps part whose runs part was never written
    orphan.write_bytes((steps_dir / part.name).read_bytes())
    (runs_dir / ".part-00000100-L0.parquet.1.tmp").write_bytes(b"half")
    assert CampaignStore(tmp_path).indices() == [0]  # the reader ignores both
    CampaignStoreWriter(tmp_path).close()
    assert not orphan.exists() and not list(runs_dir.glob(".*.tmp"))


def test_pandas_and_xarray_read_the_store_without_tubempc(tmp_path: Path) -> None:
    from tubempc.analysis.campaign import run_campaign

    run_campaign(toy_run, 5, tmp_path, 8, workers=1, progress=False)
    script = textwrap.dedent(f"""
        import json, sys
        sys.modules["tubempc"] = None  # no tubempc: importing it fails
        import pandas as pd
        runs = pd.read_parquet({str(tmp_path / "store" / "runs")!r})
        steps = pd.read_parquet({str(tmp_path / "store" / "steps")!r})
        r3 = runs.set_index("index").loc[3]
        s3 = steps[(steps["index"] == 3) & (steps["step"] == 2)].iloc[0]
        out = {{"seed": int(r3["seed"]), "J": float(r3["a.J"]), "S01": float(r3["applied.S[0][1]"]),
                "status": r3["status"], "error_1": float(s3["error[1]"]), "nees": float(s3["nees"]),
                "rows": len(steps), "columns": sorted(runs.columns)}}
        try:
            import xarray  # noqa: F401
            ds = steps.set_index(["index", "group", "step"]).to_xarray()
            out["xarray_error_1"] = float(ds["error[1]"].sel(index=3, group="a", step=2))
        except ImportError:
            pass
        print(json.dumps(out))
    """)
    got = json.loads(subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout)
    store = CampaignStore(tmp_path)
    seed = int(str(store.row(3)["seed"]))
    want = toy_run(3, seed)
    assert got["seed"] == seed and got["status"] == "ok" and got["J"] == want.result["a"]["J"]
    assert got["S01"] == want.result["applied"]["S"][0, 1]
    assert got["error_1"] == float(want.steps["a"]["error"][2, 1]) and got["nees"] == want.steps["a"]["nees"][2]
    assert got["rows"] == sum(5 + i % 3 for i in range(5))
    assert {"index", "seed", "status", "error", "traceback", "run_time_s", "a.statuses.fallback"} <= set(got["columns"])
    if "xarray_error_1" in got:
        assert got["xarray_error_1"] == float(want.steps["a"]["error"][2, 1])


def _legacy(folder: Path, n: int, master_seed: int) -> None:
    """A campaign folder as tubempc wrote it before the store: runs/run_<i>.json and .npz, one failed."""
    from tubempc.analysis.campaign import run_seed

    runs = folder / "runs"
    runs.mkdir(parents=True)
    for i in range(n):
        seed = run_seed(master_seed, i)
        if i == 1:
            rec = {"index": i, "seed": seed, "ok": False, "error": "RuntimeError: old", "traceback": "Traceback"}
            (runs / f"run_{i:05d}.failed.json").write_text(json.dumps(rec))
            continue
        out = toy_run(i, seed)
        result = json.loads(json.dumps(out.result, default=lambda a: a.tolist()))
        (runs / f"run_{i:05d}.json").write_text(json.dumps({"index": i, "seed": seed, "ok": True, "result": result}))
        np.savez_compressed(runs / f"run_{i:05d}.npz", **{f"a_{k}": v for k, v in out.steps["a"].items()})


def test_a_folder_of_the_old_layout_is_refused_then_converted(tmp_path: Path) -> None:
    from tubempc.analysis.campaign import run_campaign
    from tubempc.cli import main

    old = tmp_path / "old"
    _legacy(old, 4, 6)
    for call in (lambda: CampaignStore(old), lambda: run_campaign(toy_run, 4, old, 6, workers=1, progress=False)):
        with pytest.raises(LegacyCampaignError, match=f"tubempc campaign convert {old}"):
            call()
    assert main(["campaign", "convert", str(old)]) == 0
    assert not (old / "runs").exists()
    store = CampaignStore(old)
    assert store.indices("ok") == [0, 2, 3] and store.failures() == {1: "RuntimeError: old"}
    # the converted store, its failed run flown again, holds what a campaign of today's writes
    run_campaign(toy_run, 4, old, 6, workers=1, progress=False, retry_failed=True)
    run_campaign(toy_run, 4, tmp_path / "new", 6, workers=1, progress=False)
    got, want = contents(old), contents(tmp_path / "new")
    assert got[0].equals(want[0]) and got[1].equals(want[1])
    with pytest.raises(ValueError, match=r"no runs/run_<i>\.json"):
        main(["--debug", "campaign", "convert", str(old)])
