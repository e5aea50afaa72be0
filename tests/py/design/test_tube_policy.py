"""Background LMI designs offered to the controller (tubempc.design.policy), with scripted designers
(no SDP) where the timing matters and a real one where the numbers do."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc.design.policy import BackgroundDesigns
from tubempc.design.tube import DesignResult, DesignStatus, TubeDesigner

# Three decoupled double integrators (dt = 1): the 6-state, 3-input shape of a subsystem.
A = np.kron(np.eye(3), np.array([[1.0, 1.0], [0.0, 1.0]]))[np.ix_([0, 2, 4, 1, 3, 5], [0, 2, 4, 1, 3, 5])]
B = np.vstack([0.5 * np.eye(3), np.eye(3)])
K = np.hstack([-np.eye(3), -1.5 * np.eye(3)])  # deadbeat per axis
PE = 10.0 * np.eye(6)


def _tube(alpha: float, status: DesignStatus = DesignStatus.OPTIMAL) -> DesignResult:
    ok = status in (DesignStatus.OPTIMAL, DesignStatus.OPTIMAL_INACCURATE)
    return DesignResult(K if ok else None, PE if ok else None, alpha, 1.0, status, -1.0, 0.0, 1)


class ScriptedDesigner(TubeDesigner):
    """Returns the scripted results in order and records each call."""

    def __init__(self, results: list[DesignResult]) -> None:
        self.results = list(results)
        self.calls: list[tuple[Any, float | None]] = []
        self.spec = {}

    def design(self, A: Any, B: Any, P_W: Any, alpha_prev: float | None = None) -> DesignResult:  # type: ignore[override]
        self.calls.append((np.asarray(P_W).copy(), alpha_prev))
        return self.results.pop(0)


@dataclass
class FakeStep:
    design_due: bool
    P_W: list[Any] = field(default_factory=lambda: [1e-3 * np.eye(6)])
    A: list[Any] = field(default_factory=lambda: [A])
    B: list[Any] = field(default_factory=lambda: [B])


class FakeController:
    """Records the adoptions; its current design's alpha is 0.9."""

    def __init__(self) -> None:
        self.adopted: list[tuple[int, float, int]] = []

    def adopt(self, i: int, design: Any, k0: int) -> bool:
        self.adopted.append((i, design.alpha, k0))
        return True

    def policy(self, i: int) -> Any:
        return type("P", (), {"design": type("D", (), {"alpha": 0.9})()})()


def _fly(designs: BackgroundDesigns, ctrl: FakeController, due: set[int], n: int) -> None:
    for k in range(n):
        designs.adopt_due(k, ctrl)
        designs.submit(k, FakeStep(k in due), ctrl, 0.5)


def test_a_design_is_offered_at_a_deterministic_step() -> None:
    des = ScriptedDesigner([_tube(0.8), _tube(0.7)])
    ctrl = FakeController()
    with BackgroundDesigns([des], delay=2, worker="thread", threads=1) as designs:
        _fly(designs, ctrl, due={3, 4, 6}, n=10)
    # started at 3 (4 is due while it runs: skipped), offered before 5; started at 6, offered before 8
    assert designs.adoptions == [5, 8]
    assert ctrl.adopted == [(0, 0.8, 3), (0, 0.7, 6)]
    np.testing.assert_allclose(des.calls[0][0], 1.5e-3 * np.eye(6))  # designed for (1 + margin) P_W
    assert des.calls[0][1] == 0.9  # warm-started from the controller's current design


def test_a_failed_design_is_recorded_and_not_offered() -> None:
    des = ScriptedDesigner([_tube(0.8, DesignStatus.INFEASIBLE)])
    ctrl = FakeController()
    with BackgroundDesigns([des], delay=1, worker="inline") as designs:
        _fly(designs, ctrl, due={2}, n=5)
    assert ctrl.adopted == [] and designs.design_failures == ["2:0:INFEASIBLE"]


class BlockingDesigner(ScriptedDesigner):
    """A design that does not return until ``release`` is set."""

    def __init__(self, results: list[DesignResult]) -> None:
        super().__init__(results)
        self.release = threading.Event()
        self.returned = threading.Event()

    def design(self, A: Any, B: Any, P_W: Any, alpha_prev: float | None = None) -> DesignResult:  # type: ignore[override]
        self.release.wait(timeout=600.0)
        res = super().design(A, B, P_W, alpha_prev)
        self.returned.set()
        return res


def test_a_running_design_does_not_hold_up_the_steps() -> None:
    """With adoption when ready, 40 steps pass while the design is still running (no step waits for it,
    whatever the machine's speed); it is offered at the first step after it is done."""
    des = BlockingDesigner([_tube(0.8)])
    ctrl = FakeController()
    with BackgroundDesigns([des], delay=1, adopt_when_ready=True, worker="thread") as designs:
        _fly(designs, ctrl, due={1}, n=40)
        assert not des.returned.is_set() and designs.adoptions == [] and ctrl.adopted == []
        des.release.set()
        assert des.returned.wait(timeout=600.0)
        assert designs._pending is not None
        designs._pending[1][0].result(timeout=600.0)
        designs.adopt_due(40, ctrl)
    assert designs.adoptions == [40] and ctrl.adopted == [(0, 0.8, 1)]


def _real_designer() -> TubeDesigner:
    return TubeDesigner(Q=np.eye(6), R=np.eye(3), u_max=1.0, max_solves=3)


@pytest.mark.parametrize("worker", ["process", "inline"])
def test_every_design_worker_gives_the_threads_numbers(worker: str) -> None:
    """Deterministic adoption: the designs do not depend on where they ran (a real SDP designer, rebuilt
    from its spec in the design process)."""

    def fly(w: str) -> list[tuple[int, float, int]]:
        ctrl = FakeController()
        with BackgroundDesigns([_real_designer()], delay=2, worker=w) as designs:
            _fly(designs, ctrl, due={1, 4}, n=8)
        return ctrl.adopted

    thread, other = fly("thread"), fly(worker)
    assert len(thread) == 2 and thread == other


def test_the_design_process_never_imports_the_callers_main(tmp_path: Path) -> None:
    """A script without an ``if __name__ == "__main__"`` guard (or code piped to python) runs its background
    designs in the design process without being run again there."""
    script = tmp_path / "no_guard.py"
    script.write_text(
        textwrap.dedent(
            """
            import numpy as np
            from tubempc.design.tube import TubeDesigner
            from tubempc.design.policy import BackgroundDesigns
            print("script body ran")
            des = TubeDesigner(Q=np.eye(6), R=np.eye(3), u_max=1.0, max_solves=2)
            with BackgroundDesigns([des], delay=1, worker="process") as designs:
                pass
            """
        ),
        encoding="utf-8",
    )
    for cmd in ([sys.executable, str(script)], [sys.executable, "-"]):
        proc = subprocess.run(
            cmd,
            input=script.read_text(encoding="utf-8") if cmd[-1] == "-" else None,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.count("script body ran") == 1 and "Traceback" not in proc.stderr, proc.stderr


def test_bad_settings_are_rejected() -> None:
    with pytest.raises(ValueError, match="delay"):
        BackgroundDesigns([], delay=0)
    with pytest.raises(ValueError, match="worker"):
        BackgroundDesigns([], delay=1, worker="gpu")
    with pytest.raises(ValueError, match="concurrent worker"):
        BackgroundDesigns([], delay=1, adopt_when_ready=True, worker="inline")
