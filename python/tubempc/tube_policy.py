"""Which tube each control step flies with (paper Algorithm 1, step 1; README "readings").

TBMPC designs its tube once, at k = 0, from the identification prior and keeps it. TBMPC-FFA
re-designs it from the identified P_W: every ``alpha_search_period`` steps with a warm alpha search,
in between at the last alpha; with ``margin`` > 0 it designs for (1 + margin) P_W and keeps the
current tube (status ``KEPT``) while :func:`tubempc.tube.tube_still_valid` certifies it for the step's
linearisation and P_W. A failed design falls back to the designer's last feasible tube, else to the
current one; a failed first design is an error.

With ``update = "lyapunov"`` (TBMPC-FFA) the LMI design runs only on the alpha-search steps; at
every other step the tube is the certified Lyapunov update of the last design's K and alpha for the
step's linearisation and identified P_W, inflated by (1 + ``margin``) as the designs are
(:func:`tubempc.tube.lyapunov_tube`, status ``LYAPUNOV``),
or, when the margin cannot be kept (a disturbance grown since the design), the update for the identified
P_W itself (``LYAPUNOV_NO_MARGIN``, and the next step starts a design); when even that cannot be certified,
an LMI design in the step itself (``SYNC_<status>``; if it fails, the last certified tube). With
``design_delay`` = 0 the designs run synchronously at those steps. With ``design_delay`` = d >= 1 they
run off the critical path, in the ``worker``: "process" (a separate process, so that the cvxpy work
never holds the control loop's GIL), "thread" (a background thread) or "inline" (at the search step
itself: no concurrency, for campaigns whose processes already fill every core). A design is
submitted at the search step and adopted (its K and alpha, from then on in the Lyapunov update) at
step k + d, a deterministic step, so a run is reproducible and gives the same numbers with every
worker. In real time d dt = 2d s leaves the design ample time; a simulation running faster than real
time may have to wait for it at the adoption step: that wait is pacing, not controller time, and is
reported apart (``last_wait_s``). ``adopt_when_ready`` adopts at the first step after the design is
done instead and never waits (flight-like; the adoption step then depends on the machine).
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import pickle
import signal
import threading
import time
import warnings
from collections.abc import Sequence
from concurrent.futures.process import BrokenProcessPool

import numpy as np
import numpy.typing as npt

from .tube import TubeDesigner, TubeResult, lyapunov_tube, tube_still_valid

__all__ = ["DESIGN_WORKERS", "TubeUpdatePolicy", "shutdown_design_worker"]

Array = npt.NDArray[np.float64]

DESIGN_WORKERS = ("process", "thread", "inline")

# One subsystem's design: its designer, A, B, the P_W designed for and the previous alpha.
_DesignArgs = tuple[TubeDesigner, Array, Array, Array, float | None]

# The process that runs background designs: one per Python process, started on first use and shared
# by every policy (its start-up, mostly importing cvxpy, is paid once); its designers are rebuilt
# from their spec once and kept.
_PROCESS_POOL: cf.ProcessPoolExecutor | None = None
_PROCESS_LOCK = threading.Lock()
_WORKER_DESIGNERS: dict[bytes, TubeDesigner] = {}


def _process_pool() -> cf.ProcessPoolExecutor:
    global _PROCESS_POOL
    with _PROCESS_LOCK:
        if _PROCESS_POOL is None:
            ctx = multiprocessing.get_context("spawn")  # no fork of a process with threads
            _PROCESS_POOL = cf.ProcessPoolExecutor(
                max_workers=1, mp_context=ctx, initializer=_worker_init, initargs=(os.getpid(),)
            )
        return _PROCESS_POOL


def shutdown_design_worker(wait: bool = True) -> None:
    """Stops the background design process (if started); ``wait=False`` (Ctrl-C) cancels what has not
    started, terminates this process's children and returns at once."""
    global _PROCESS_POOL
    with _PROCESS_LOCK:
        pool, _PROCESS_POOL = _PROCESS_POOL, None
    if pool is not None:
        if not wait:  # the process may still be starting (importing cvxpy): end it now
            for child in multiprocessing.active_children():
                child.terminate()
        pool.shutdown(wait=wait, cancel_futures=True)


def _worker_init(parent: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _watch_parent(parent: int) -> None:
    """Ends the design process within 0.2 s once its parent is gone (a parent that exits through
    os._exit, or is killed, never shuts the pool down), also when it was gone before this started."""
    while os.getppid() == parent:
        time.sleep(0.2)
    os._exit(0)


def _worker_designer(key: bytes) -> TubeDesigner:
    des = _WORKER_DESIGNERS.get(key)
    if des is None:
        des = _WORKER_DESIGNERS[key] = TubeDesigner(**pickle.loads(key))
    return des


def _warm_worker(key: bytes) -> None:
    _worker_designer(key)


def _design_in_worker(key: bytes, A: Array, B: Array, P_W: Array, alpha_prev: float | None) -> TubeResult:
    return _worker_designer(key).design(A, B, P_W, alpha_prev)


class TubeUpdatePolicy:
    """The tube of each subsystem, step by step.

    ``designers``: one :class:`tubempc.tube.TubeDesigner` per subsystem; ``adaptive``: False for
    TBMPC (design once), True for TBMPC-FFA; ``margin``: design for (1 + margin) P_W and keep a
    certified tube (FFA only); ``alpha_search_period``: steps between warm alpha searches;
    ``threads``: subsystems designed in parallel threads (1: one after the other).
    """

    def __init__(
        self,
        designers: Sequence[TubeDesigner],
        *,
        adaptive: bool,
        margin: float = 0.0,
        alpha_search_period: int = 1,
        threads: int = 2,
        update: str = "lmi",
        design_delay: int = 0,
        adopt_when_ready: bool = False,
        worker: str = "process",
    ) -> None:
        if alpha_search_period < 1:
            raise ValueError(f"alpha_search_period must be >= 1, got {alpha_search_period}")
        if margin < 0.0:
            raise ValueError(f"margin must be >= 0, got {margin}")
        if update not in ("lmi", "lyapunov"):
            raise ValueError(f"update must be 'lmi' or 'lyapunov', got {update!r}")
        if design_delay < 0:
            raise ValueError(f"design_delay must be >= 0 steps, got {design_delay}")
        if worker not in DESIGN_WORKERS:
            raise ValueError(f"worker must be one of {DESIGN_WORKERS}, got {worker!r}")
        if adopt_when_ready and worker == "inline":
            raise ValueError("adopt_when_ready needs a concurrent worker ('process' or 'thread')")
        self.update_kind = update
        self.design_delay = design_delay
        self.adopt_when_ready = adopt_when_ready
        self.adoptions: list[int] = []  # steps at which a background design was adopted
        # LMI designs that failed, "<step started>:<subsystem>:<status>" (their tube was not used)
        self.design_failures: list[str] = []
        self.last_wait_s = 0.0  # time the last update waited for a due design (pacing, not control)
        # a background design in flight: the step it started, its futures and each subsystem's arguments
        self._pending: tuple[int, list[cf.Future[TubeResult]], list[_DesignArgs]] | None = None
        # the last Lyapunov update could not keep the margin: the next step starts a design (lyapunov update)
        self._margin_lost = False
        self.designers = list(designers)
        self.adaptive = adaptive
        self.margin = margin if adaptive else 0.0
        self.alpha_search_period = alpha_search_period
        self.tubes: list[TubeResult] | None = None
        self._designed_for: list[Array | None] = [None] * len(self.designers)  # the P_W of each tube
        self._designed: list[TubeResult | None] = [None] * len(self.designers)  # each one's last LMI design
        self._sync_step = [-1] * len(self.designers)  # the step of each one's last in-step (SYNC) design
        self._pool = cf.ThreadPoolExecutor(max_workers=max(1, min(len(self.designers), int(threads))))
        self.worker = worker
        self._keys: list[bytes] = []
        if update == "lyapunov" and design_delay > 0 and worker == "process" and adaptive:
            self._keys = [pickle.dumps(d.spec) for d in self.designers]
            # Start the worker and build its designers now, in the set-up, not in a control step.
            try:
                for key in self._keys:
                    _process_pool().submit(_warm_worker, key).result()
            except BrokenProcessPool as exc:
                self._to_thread(exc)

    def _to_thread(self, exc: BaseException) -> None:
        """The documented fallback when the design process cannot run (e.g. a main script that a
        spawned process cannot import, such as code piped to ``python -``): designs go to a thread."""
        warnings.warn(
            f"tube design process unavailable ({type(exc).__name__}: {exc}); designs run in a thread instead",
            RuntimeWarning,
            stacklevel=3,
        )
        shutdown_design_worker(wait=False)
        self.worker = "thread"

    def close(self, wait: bool = True) -> None:
        """Stops the design threads; ``wait=False`` returns at once (a running design finishes alone).
        The shared design process stays up for the next policy; a pending design of this one is
        cancelled if it has not started."""
        if self._pending is not None:
            for future in self._pending[1]:
                future.cancel()
        self._pool.shutdown(wait=wait, cancel_futures=not wait)

    def __enter__(self) -> TubeUpdatePolicy:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(wait=exc_type is None)

    def update(
        self, k: int, A: Sequence[Array], B: Sequence[Array], P_W: Sequence[Array]
    ) -> tuple[list[TubeResult], str | None]:
        """The tubes for step ``k`` given each subsystem's discretised (A, B) about the reference and
        identified P_W. Returns the tubes and the step's status ("<status>/<status>", None when the
        policy did not look at the tubes: TBMPC after k = 0)."""
        self.last_wait_s = 0.0
        if self.tubes is not None and not self.adaptive:
            return self.tubes, None
        search = k % self.alpha_search_period == 0
        if self.update_kind == "lyapunov" and self.tubes is not None:
            if self.design_delay > 0:
                self._background(k, search, A, B, P_W)
                return self._lyapunov(k, A, B, P_W)
            if not search:
                return self._lyapunov(k, A, B, P_W)
        jobs: list[tuple[cf.Future[TubeResult], Array] | None] = []
        for i, des in enumerate(self.designers):
            prev = None if self.tubes is None else self.tubes[i]
            designed_for = self._designed_for[i]
            if (
                prev is not None
                and designed_for is not None
                and not search
                and self.margin > 0.0
                and tube_still_valid(prev, A[i], B[i], P_W[i], designed_for, self.margin)
            ):
                jobs.append(None)
                continue
            P_design = (1.0 + self.margin) * P_W[i]
            alpha_prev = prev.alpha if prev is not None and prev.feasible else None
            if alpha_prev is not None and not search:
                future = self._pool.submit(des.design_fixed_alpha, A[i], B[i], P_design, alpha_prev)
            else:
                future = self._pool.submit(des.design, A[i], B[i], P_design, alpha_prev)
            jobs.append((future, P_design))
        tubes: list[TubeResult] = []
        names: list[str] = []
        for i, job in enumerate(jobs):
            if job is None:
                assert self.tubes is not None
                tubes.append(self.tubes[i])
                names.append("KEPT")
                continue
            res = job[0].result()
            names.append(res.status.name)
            if not res.feasible:
                self.design_failures.append(f"{k}:{i}:{res.status.name}")
            last = self.designers[i].last_feasible
            if res.feasible:
                tubes.append(res)
                self._designed_for[i] = job[1]
                self._designed[i] = res
            elif last is not None:
                tubes.append(last)
            elif self.tubes is not None:
                tubes.append(self.tubes[i])
            else:
                raise RuntimeError(
                    f"initial tube design infeasible ({res.status.name}); check identification priors and input limits"
                )
        self.tubes = tubes
        return tubes, "/".join(names)

    def _lyapunov(
        self, k: int, A: Sequence[Array], B: Sequence[Array], P_W: Sequence[Array]
    ) -> tuple[list[TubeResult], str]:
        assert self.tubes is not None
        tubes: list[TubeResult] = []
        names: list[str] = []
        for i, des in enumerate(self.designers):
            design = self._designed[i]
            tube = None if design is None else lyapunov_tube(A[i], B[i], design, (1.0 + self.margin) * P_W[i], des.u_max)[0]
            name = "LYAPUNOV"
            if tube is None and design is not None and self.margin > 0.0:
                # Certified for the identified P_W itself, without the margin (which a disturbance growing
                # since the design has used up): still robust for the identified set.
                tube = lyapunov_tube(A[i], B[i], design, P_W[i], des.u_max)[0]
                name = "LYAPUNOV_NO_MARGIN"
            if tube is None:
                # Nothing certified for this step's P_W: an LMI design now, in this step (tens of ms, rare),
                # so that every step flies a tube certified for the identified set while the LMI is feasible.
                P_design = (1.0 + self.margin) * P_W[i]
                res = des.design(A[i], B[i], P_design, None if design is None else design.alpha)
                name = f"SYNC_{res.status.name}"
                if res.feasible:
                    tube = res
                    self._designed[i], self._designed_for[i], self._sync_step[i] = res, P_design, k
                else:
                    self.design_failures.append(f"{k}:{i}:{res.status.name}")
            tubes.append(self.tubes[i] if tube is None else tube)  # SYNC_<failure>: the last certified tube
            names.append(name)
        self._margin_lost = any(n != "LYAPUNOV" for n in names)
        self.tubes = tubes
        return tubes, "/".join(names)

    def _background(self, k: int, search: bool, A: Sequence[Array], B: Sequence[Array], P_W: Sequence[Array]) -> None:
        """Adopts a finished (or due) background design; starts one on a search step, or on the step after
        a Lyapunov update that could not keep the margin (a disturbance grown since the last design)."""
        if self._pending is not None:
            k0, futures, args = self._pending
            due = all(f.done() for f in futures) if self.adopt_when_ready else k >= k0 + self.design_delay
            if due:
                t0 = time.perf_counter()
                try:
                    results = [future.result() for future in futures]  # waits only for a due design not yet done
                except BrokenProcessPool as exc:  # the design process died: this design is redone in a thread
                    self._to_thread(exc)
                    results = [self._submit(i, *a).result() for i, a in enumerate(args)]
                self.last_wait_s = time.perf_counter() - t0
                for i, res in enumerate(results):
                    if not res.feasible:
                        self.design_failures.append(f"{k0}:{i}:{res.status.name}")
                    elif k0 > self._sync_step[i]:  # an in-step design since k0 is newer: keep it
                        self._designed[i] = res
                        self._designed_for[i] = args[i][3]  # the P_W it was designed for
                self._pending = None
                self.adoptions.append(k)
        if (search or self._margin_lost) and self._pending is None:
            jobs: list[_DesignArgs] = [
                (des, A[i], B[i], (1.0 + self.margin) * P_W[i], None if d is None else d.alpha)
                for i, (des, d) in enumerate(zip(self.designers, self._designed, strict=True))
            ]
            self._pending = (k, [self._submit(i, *job) for i, job in enumerate(jobs)], jobs)

    def _submit(
        self, i: int, des: TubeDesigner, A: Array, B: Array, P_W: Array, alpha_prev: float | None
    ) -> cf.Future[TubeResult]:
        if self.worker == "process":
            return _process_pool().submit(_design_in_worker, self._keys[i], A, B, P_W, alpha_prev)
        if self.worker == "thread":
            return self._pool.submit(des.design, A, B, P_W, alpha_prev)
        future: cf.Future[TubeResult] = cf.Future()
        future.set_result(des.design(A, B, P_W, alpha_prev))
        return future
