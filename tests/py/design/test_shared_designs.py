"""A campaign's set-up designs made once and adopted by its workers: the same bits, no design in the worker."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import tubempc.design.library as library
from tubempc.config import load_config
from tubempc.design.library import adopt_shared_designs, controller_designs, shared_designs
from tubempc.scenario import build_scenario
from tubempc.sim.closed_loop import simulate


def test_a_worker_flies_the_shared_designs_to_the_bit_without_designing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cfg = load_config()
    here = build_scenario(cfg, cache_dir=tmp_path)
    shared = pickle.loads(pickle.dumps(shared_designs(here, ("tbmpc", "ffa"))))  # as a worker receives them
    assert len(shared["ffa"]["library_p"]) > 1 and shared["tbmpc"]["library_p"] == []
    worker = build_scenario(cfg, cache_dir=tmp_path)
    assert "designs:ffa" not in worker.tube_designs
    adopt_shared_designs(worker, shared)

    def no_design(*_: object, **__: object) -> None:
        raise AssertionError("the worker designed a tube")

    monkeypatch.setattr(library, "tube_designers", no_design)
    for m in ("tbmpc", "ffa"):
        mine, theirs = controller_designs(here, m), controller_designs(worker, m)
        for name in ("initial_p", "initial_r"):
            a, b = getattr(mine, name), getattr(theirs, name)
            assert a.alpha == b.alpha and all(np.array_equal(getattr(a, f), getattr(b, f)) for f in ("K", "P_W", "Pe"))
        assert len(mine.library_p) == len(theirs.library_p) and len(mine.library_r) == len(theirs.library_r)
        x_here = simulate(here, m, 3, max_steps=4, design_worker="inline").x
        x_worker = simulate(worker, m, 3, max_steps=4, design_worker="inline").x
        assert x_here.tobytes() == x_worker.tobytes()
