"""Background LMI designs offered to the C++ controller (docs/model.md "Tube update").

The tube of every step is the C++ controller's (``_core.control.Controller``: certified Lyapunov
updates of the current design, the set-up library where that fails; no semidefinite program inside a
step). When a new design is due (``ControlStep.design_due``: every ``alpha_search_period`` steps and
after a step that could not keep the margin), :class:`BackgroundDesigns` runs the LMI design of each
subsystem from that step's (A, B, (1 + margin) P_W) off the critical path, in the ``worker``:
"process" (a separate Python process, started with ``python -m tubempc.design.policy``, so that the cvxpy
work never holds the control loop's GIL and the caller's ``__main__`` is never imported again),
"thread" (a background thread) or "inline" (at the step itself, for campaigns whose processes
already fill every core). A design started at step k0 is offered to the controller
(``Controller.adopt``) before step k0 + ``delay``, a deterministic step, so a run is reproducible and
gives the same numbers with every worker; a simulation running faster than real time may have to wait
for it then: that wait is pacing, not controller time, and is reported apart (``last_wait_s``).
``adopt_when_ready`` offers it at the first step after it is done instead and never waits (flight-like;
the adoption step then depends on the machine).
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import pickle
import signal
import struct
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Sequence
from typing import IO, Any

import numpy as np
import numpy.typing as npt

from .tube import DesignResult, TubeDesigner

__all__ = ["DESIGN_WORKERS", "BackgroundDesigns", "shutdown_design_worker"]

Array = npt.NDArray[np.float64]

DESIGN_WORKERS = ("process", "thread", "inline")


def _send(stream: IO[bytes], obj: object) -> None:
    data = pickle.dumps(obj)
    stream.write(struct.pack("<Q", len(data)) + data)
    stream.flush()


def _receive(stream: IO[bytes]) -> Any:
    head = stream.read(8)
    if len(head) < 8:
        raise EOFError
    (n,) = struct.unpack("<Q", head)
    return pickle.loads(stream.read(n))


class _DesignProcess:
    """The process that runs background designs: one per Python process, started on first use and shared
    by every run (its start-up, mostly importing cvxpy, is paid once); it keeps the designers it built
    from their spec. It ends when its standard input closes (the parent exited or was killed)."""

    def __init__(self) -> None:
        self._proc = subprocess.Popen(
            [sys.executable, "-m", "tubempc.design.policy"], stdin=subprocess.PIPE, stdout=subprocess.PIPE
        )
        self._ids = itertools.count()
        self._futures: dict[int, cf.Future[Any]] = {}
        self._ended = False
        self._lock = threading.Lock()
        threading.Thread(target=self._read, daemon=True).start()

    def submit(self, *job: object) -> cf.Future[Any]:
        future: cf.Future[Any] = cf.Future()
        future.set_running_or_notify_cancel()  # a job sent cannot be called back
        with self._lock:
            if self._ended:
                future.set_exception(RuntimeError("the tube design process ended"))
                return future
            job_id = next(self._ids)
            self._futures[job_id] = future
            assert self._proc.stdin is not None
            try:
                _send(self._proc.stdin, (job_id, *job))
            except OSError as exc:
                del self._futures[job_id]
                future.set_exception(RuntimeError(f"the tube design process is gone: {exc}"))
        return future

    def _read(self) -> None:
        assert self._proc.stdout is not None
        while True:
            try:
                job_id, ok, value = _receive(self._proc.stdout)
            except (EOFError, OSError, pickle.UnpicklingError, ValueError):
                break
            with self._lock:
                future = self._futures.pop(job_id, None)
            if future is None:
                continue
            if ok:
                future.set_result(value)
            else:
                future.set_exception(RuntimeError(value))
        with self._lock:
            self._ended = True
            pending, self._futures = self._futures, {}
        for future in pending.values():
            future.set_exception(RuntimeError("the tube design process ended"))

    def close(self, wait: bool) -> None:
        if self._proc.stdin is not None:
            self._proc.stdin.close()
        if not wait:
            self._proc.kill()
        self._proc.wait()
        if self._proc.stdout is not None:
            self._proc.stdout.close()


_PROCESS: _DesignProcess | None = None
_PROCESS_LOCK = threading.Lock()


def _design_process() -> _DesignProcess:
    global _PROCESS
    with _PROCESS_LOCK:
        if _PROCESS is None:
            _PROCESS = _DesignProcess()
        return _PROCESS


def shutdown_design_worker(wait: bool = True) -> None:
    """Stops the background design process (if started); ``wait=False`` (Ctrl-C) kills it at once."""
    global _PROCESS
    with _PROCESS_LOCK:
        proc, _PROCESS = _PROCESS, None
    if proc is not None:
        proc.close(wait)


def _worker_main() -> None:
    """The design process: reads (id, spec, A, B, P_W, alpha_prev) jobs from stdin, writes (id, ok, result)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    designers: dict[bytes, TubeDesigner] = {}
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # nothing printed by a library may enter the protocol
    while True:
        try:
            job_id, key, A, B, P_W, alpha_prev = _receive(stdin)
        except EOFError:
            return
        try:
            des = designers.get(key)
            if des is None:
                des = designers[key] = TubeDesigner(**pickle.loads(key))
            reply: tuple[int, bool, object] = (
                job_id,
                True,
                None if A is None else des.design(A, B, P_W, alpha_prev),
            )
        except Exception as exc:  # reported to the parent, which records the design as failed
            reply = (job_id, False, f"{type(exc).__name__}: {exc}")
        _send(stdout, reply)


#: Seconds the design process may take to start (import cvxpy, build the designers) before the designs
#: fall back to a thread.
_START_TIMEOUT_S = 300.0

# One subsystem's design: A, B, the P_W designed for and the previous alpha.
_DesignArgs = tuple[Array, Array, Array, float | None]


class BackgroundDesigns:
    """LMI designs of the subsystems (one :class:`tubempc.design.tube.TubeDesigner` each) offered to a
    ``_core.control.Controller`` ``delay`` >= 1 steps after they start (see the module doc)."""

    def __init__(
        self,
        designers: Sequence[TubeDesigner],
        *,
        delay: int,
        adopt_when_ready: bool = False,
        worker: str = "process",
        threads: int = 2,
    ) -> None:
        if delay < 1:
            raise ValueError(f"delay must be >= 1 steps, got {delay}")
        if worker not in DESIGN_WORKERS:
            raise ValueError(f"worker must be one of {DESIGN_WORKERS}, got {worker!r}")
        if adopt_when_ready and worker == "inline":
            raise ValueError("adopt_when_ready needs a concurrent worker ('process' or 'thread')")
        self.designers = list(designers)
        self.delay = delay
        self.adopt_when_ready = adopt_when_ready
        self.worker = worker
        self.adoptions: list[int] = []  # steps before which a design was offered
        self.design_failures: list[str] = []  # "<step started>:<subsystem>:<status>"
        self.last_wait_s = 0.0
        self._pending: tuple[int, list[cf.Future[DesignResult]], list[_DesignArgs]] | None = None
        self._pool = cf.ThreadPoolExecutor(max_workers=max(1, min(len(self.designers), int(threads))))
        self._keys = [pickle.dumps(d.spec) for d in self.designers]
        if worker == "process":
            # Start the process and build its designers now, in the set-up, not in a control step; if it
            # cannot run (no working interpreter, killed), the documented fallback: designs in a thread.
            try:
                for key in self._keys:
                    _design_process().submit(key, None, None, None, None).result(timeout=_START_TIMEOUT_S)
            except (RuntimeError, cf.TimeoutError) as exc:
                warnings.warn(
                    f"tube design process unavailable ({exc}); designs run in a thread instead",
                    RuntimeWarning,
                    stacklevel=2,
                )
                shutdown_design_worker(wait=False)
                self.worker = "thread"

    def close(self, wait: bool = True) -> None:
        """Stops the design threads (the shared design process stays up for the next run)."""
        if self._pending is not None:
            for future in self._pending[1]:
                future.cancel()
        self._pool.shutdown(wait=wait, cancel_futures=not wait)

    def __enter__(self) -> BackgroundDesigns:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(wait=exc_type is None)

    def adopt_due(self, k: int, ctrl: Any) -> None:
        """Before step k: offers a finished (or due) design to ``ctrl`` (``Controller.adopt``)."""
        self.last_wait_s = 0.0
        if self._pending is None:
            return
        k0, futures, args = self._pending
        due = all(f.done() for f in futures) if self.adopt_when_ready else k >= k0 + self.delay
        if not due:
            return
        t0 = time.perf_counter()
        results: list[DesignResult | None] = []
        for i, future in enumerate(futures):
            try:
                results.append(future.result())  # waits only for a due design not yet done
            except RuntimeError as exc:
                self.design_failures.append(f"{k0}:{i}:ERROR ({exc})")
                results.append(None)
        self.last_wait_s = time.perf_counter() - t0
        from .library import subsystem_design  # here: the design process needs none of its imports

        for i, res in enumerate(results):
            if res is None:
                continue
            if not res.feasible:
                self.design_failures.append(f"{k0}:{i}:{res.status.name}")
            else:
                ctrl.adopt(i, subsystem_design(res, args[i][2]), k0)
        self._pending = None
        self.adoptions.append(k)

    def submit(self, k: int, step: Any, ctrl: Any, margin: float) -> None:
        """After step k: starts a design from the step's (A, B, (1 + margin) P_W) when one is due
        (``step.design_due``) and none is running."""
        if not step.design_due or self._pending is not None:
            return
        jobs: list[_DesignArgs] = [
            (
                np.asarray(step.A[i]),
                np.asarray(step.B[i]),
                (1.0 + margin) * np.asarray(step.P_W[i]),
                float(ctrl.policy(i).design.alpha),
            )
            for i in range(len(self.designers))
        ]
        self._pending = (k, [self._submit(i, *job) for i, job in enumerate(jobs)], jobs)

    def _submit(self, i: int, A: Array, B: Array, P_W: Array, alpha_prev: float | None) -> cf.Future[DesignResult]:
        des = self.designers[i]
        if self.worker == "process":
            return _design_process().submit(self._keys[i], A, B, P_W, alpha_prev)
        if self.worker == "thread":
            return self._pool.submit(des.design, A, B, P_W, alpha_prev)
        future: cf.Future[DesignResult] = cf.Future()
        future.set_result(des.design(A, B, P_W, alpha_prev))
        return future


if __name__ == "__main__":
    _worker_main()
