"""The record of a closed-loop run and its self-describing HDF5 file.

:class:`RunRecord` declares every array of a run once, with its shape and unit; :func:`save_record`
writes it (the one writer) and :func:`load_record` reads it back (the one reader).

File layout: every array is a dataset at the root (``/x``, ``/u``, ...; units in the dataset attribute
``units``), and the root attributes hold ``config`` (JSON of the full configuration), ``seed``,
``method``, ``tubempc_version`` and ``metadata`` (JSON of anything else, e.g. metrics).
:func:`save_result` / :func:`load_result` are the generic layer underneath.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import numpy.typing as npt

from .. import __version__

__all__ = ["RunRecord", "load_record", "load_result", "save_record", "save_result"]

Array = npt.NDArray[np.float64]
#: Columns of RunRecord.thruster_on_time (actuators::kMaxThrusters).
MAX_THRUSTERS = 32
_STATE = "[m, m/s, rad, rad/s]"  # x = [r_L, v_L, phi, omega_BL_B]
_INPUT = "[m/s^2 (L), N m (B)]"  # u = [u_p, T]


def _array(shape: tuple[str | int, ...], unit: str, doc: str) -> Any:
    """A declared array of the record: shape in the symbols T (steps) and N (horizon), unit, meaning."""
    return field(default_factory=lambda: np.zeros(0), metadata={"shape": shape, "unit": unit, "doc": doc})


@dataclass
class RunRecord:
    """Every array of one closed-loop run, declared once with its shape (T steps, horizon N) and unit,
    plus the per-step statuses and the run's facts."""

    method: str
    seed: int
    t: Array = _array(("T+1",), "s", "time of each state x_k")
    x: Array = _array(("T+1", 12), _STATE, "measured state x_k")
    zbar: Array = _array(("T+1", 12), _STATE, "reference state")
    ubar: Array = _array(("T", 6), _INPUT, "reference input")
    z: Array = _array(("T", 12), _STATE, "nominal state z*_0|k of the step's plan")
    z_plan: Array = _array(("T", "N+1", 12), _STATE, "the step's nominal plan z*_{0..N|k}")
    u: Array = _array(("T", 6), _INPUT, "applied input (ancillary law, saturated)")
    v: Array = _array(("T", 6), _INPUT, "nominal input v*_0|k")
    K: Array = _array(("T", 6, 12), "[m/s^2, N m] per state unit", "ancillary gain")
    Pe_p: Array = _array(("T", 6, 6), "[m, m/s]^2", "translational tube shape")
    Pe_r: Array = _array(("T", 6, 6), "[rad, rad/s]^2", "rotational tube shape")
    alpha: Array = _array(("T", 2), "1", "tube contraction alpha (translation, rotation)")
    w: Array = _array(("T", 12), _STATE, "measured exogenous input w_k")
    w_true: Array = _array(("T", 12), _STATE, "simulated additive disturbance")
    w_hat: Array = _array(("T", 12), _STATE, "identified disturbance mean after step k")
    S_p: Array = _array(("T", 6, 6), "[m, m/s]^2", "identified translational covariance after step k")
    S_r: Array = _array(("T", 6, 6), "[rad, rad/s]^2", "identified rotational covariance after step k")
    g: Array = _array(("T+1", 2), "m", "glide-slope and line-of-sight constraint values (> 0: violated)")
    excursion: Array = _array(("T", 2), "1", "tube excursion e^T Pe^-1 e of x_{k+1} - z*_1|k (> 1: outside)")
    scp_iterations: Array = _array(("T",), "1", "SCP iterations (QPs) of the step")
    qp_iterations: Array = _array(("T",), "1", "QP solver iterations of the step")
    active_set_solves: Array = _array(("T",), "1", "QPs of the step solved by the active set")
    model_evaluations: Array = _array(("T",), "1", "model linearisations of the step")
    time_tube: Array = _array(("T",), "s", "wall time of the tube update (a design wait excluded)")
    time_design_wait: Array = _array(
        ("T",), "s", "wait for a due background design (a simulation faster than real time; not control time)"
    )
    time_linearize: Array = _array(("T",), "s", "wall time of the MPC's linearisation")
    time_build: Array = _array(("T",), "s", "wall time of the MPC's QP assembly")
    time_solve: Array = _array(("T",), "s", "wall time of the MPC's QP solves")
    time_mpc: Array = _array(("T",), "s", "wall time of the MPC step")
    time_propagate: Array = _array(("T",), "s", "wall time of the truth propagation")
    time_identify: Array = _array(("T",), "s", "wall time of the identification (the last period's input folded in)")
    time_predict: Array = _array(
        ("T",), "s", "wall time of the one-step prediction after the command (the next identification's input)"
    )
    time_step: Array = _array(("T",), "s", "wall time of the whole control step")
    u_delivered: Array = _array(("T", 6), _INPUT, "input the actuators delivered over the period (its average)")
    delta_v: Array = _array(
        ("T",), "m/s", "thruster delta-v of the period, sum of impulses / m (ideal: the norm of u_p times dt)"
    )
    propellant: Array = _array(("T",), "kg", "propellant of the period (0 for ideal actuators)")
    pulses: Array = _array(("T",), "1", "thruster firings of the period")
    wheel_momentum: Array = _array(("T", 3), "N m s", "the wheels' total momentum in B after the period")
    time_actuation: Array = _array(("T",), "s", "wall time of the actuation call (allocation, modulation, wheels)")
    thruster_on_time: Array = _array(
        ("T", MAX_THRUSTERS), "s", "on-time of each thruster in the period (its first n columns; 0 if ideal)"
    )
    statuses: list[str] = field(default_factory=list)  # MPC step status per step
    failures: list[str] = field(default_factory=list)  # cause of each fallback ("solved": none)
    tube_statuses: list[str] = field(default_factory=list)  # per tube update: "<translation>/<rotation>"
    design_failures: list[str] = field(default_factory=list)  # failed LMI designs: "<step>:<subsystem>:<status>"
    actuation_statuses: list[str] = field(default_factory=list)  # actuators::AllocationStatus per step ("ideal")
    wall_time_s: float = 0.0
    # What the run actually applied: its seeds, the disturbance model, the actuator errors drawn, the
    # truth's physical mismatches (closed_loop.simulate; Monte Carlo runs keep it in their records).
    applied: dict[str, Any] = field(default_factory=dict)
    # The navigation of a run flown on the estimate (tubempc.scenario.navigation.NavigationRecord), else None.
    navigation: Any = None

    @staticmethod
    def array_fields() -> list[dataclasses.Field[Any]]:
        """The declared arrays (fields with a shape and a unit)."""
        return [f for f in dataclasses.fields(RunRecord) if "shape" in f.metadata]

    @classmethod
    def allocate(cls, method: str, seed: int, n_steps: int, horizon: int) -> RunRecord:
        """A record of zeros for T = ``n_steps`` steps and horizon N = ``horizon``."""
        sizes = {"T": n_steps, "T+1": n_steps + 1, "N+1": horizon + 1}
        rec = cls(method=method, seed=seed)
        for f in cls.array_fields():
            setattr(rec, f.name, np.zeros(tuple(sizes.get(d, d) for d in f.metadata["shape"])))
        return rec

    def truncate(self, n_run: int) -> None:
        """Cuts every array to the first ``n_run`` steps (a run stopped early)."""
        for f in self.array_fields():
            keep = n_run + 1 if f.metadata["shape"][0] == "T+1" else n_run
            setattr(self, f.name, getattr(self, f.name)[:keep])

    @property
    def n_steps(self) -> int:
        """Number of steps recorded."""
        return int(self.u.shape[0])

    @staticmethod
    def units() -> dict[str, str]:
        """Unit of every declared array."""
        return {f.name: f.metadata["unit"] for f in RunRecord.array_fields()}


def save_result(
    path: str | Path,
    arrays: Mapping[str, Any],
    *,
    config: Mapping[str, Any],
    seed: int | None,
    method: str,
    units: Mapping[str, str] | None = None,
    metadata: Mapping[str, Any] | None = None,
) -> Path:
    """Writes ``arrays`` with the configuration and seed that produced them; returns the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_name(f".{p.name}.tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs["config"] = json.dumps(config, sort_keys=True)
        f.attrs["seed"] = -1 if seed is None else int(seed)
        f.attrs["method"] = method
        f.attrs["tubempc_version"] = __version__
        f.attrs["metadata"] = json.dumps(metadata or {}, sort_keys=True, default=float)
        for name, value in arrays.items():
            arr = np.asarray(value)
            if arr.dtype.kind in "US":
                arr = arr.astype("S")
            ds = f.create_dataset(name, data=arr, compression="gzip" if arr.size > 1024 else None)
            if units and name in units:
                ds.attrs["units"] = units[name]
    tmp.replace(p)
    return p


def load_result(path: str | Path) -> dict[str, Any]:
    """Reads a file written by :func:`save_result` into a dict: arrays by name plus ``config``,
    ``seed``, ``method``, ``tubempc_version``, ``metadata`` and ``units``."""
    p = Path(path)
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise ValueError(f"{p}: not a tubempc result file ({exc})") from exc
    with f:
        missing = [k for k in ("config", "seed", "method") if k not in f.attrs]
        if missing:
            raise ValueError(f"{p}: not a tubempc result file (missing attributes {missing})")
        out: dict[str, Any] = {
            "config": json.loads(f.attrs["config"]),
            "seed": None if int(f.attrs["seed"]) < 0 else int(f.attrs["seed"]),
            "method": str(f.attrs["method"]),
            "tubempc_version": str(f.attrs.get("tubempc_version", "")),
            "metadata": json.loads(f.attrs.get("metadata", "{}")),
            "units": {},
        }
        for name, ds in f.items():
            data = ds[()]
            is_bytes = getattr(data, "dtype", None) is not None and data.dtype.kind == "S"
            out[name] = data.astype(str) if is_bytes else data
            if "units" in ds.attrs:
                out["units"][name] = str(ds.attrs["units"])
    return out


#: Arrays added with the actuator model (issue #31) and their trailing shapes.
_ACTUATION_ARRAYS: dict[str, tuple[int, ...]] = {
    "u_delivered": (6,),
    "delta_v": (),
    "propellant": (),
    "pulses": (),
    "wheel_momentum": (3,),
    "time_actuation": (),
    "thruster_on_time": (MAX_THRUSTERS,),
}


def save_record(
    path: str | Path, record: RunRecord, *, config: Mapping[str, Any], metadata: Mapping[str, Any] | None = None
) -> Path:
    """Writes a run's record (every declared array with its unit, the statuses, the configuration
    and the seed) to an HDF5 file; returns the path."""
    arrays: dict[str, Any] = {f.name: getattr(record, f.name) for f in RunRecord.array_fields()}
    arrays.update(
        status=np.array(record.statuses),
        failure=np.array(record.failures),
        tube_status=np.array(record.tube_statuses),
        design_failure=np.array(record.design_failures, dtype=str),
        actuation_status=np.array(record.actuation_statuses, dtype=str),
    )
    if record.navigation is not None:
        arrays.update(record.navigation.arrays())
    meta = {"wall_time_s": record.wall_time_s, "applied": record.applied, **(metadata or {})}
    return save_result(
        path, arrays, config=config, seed=record.seed, method=record.method, units=RunRecord.units(), metadata=meta
    )


def load_record(path: str | Path) -> tuple[RunRecord, dict[str, Any]]:
    """Reads a file written by :func:`save_record`: the record and the file's ``config``, ``metadata``
    and ``tubempc_version``."""
    raw = load_result(path)
    if "time_design_wait" not in raw and "time_tube" in raw:  # a record from before this field: no wait recorded
        raw["time_design_wait"] = np.zeros_like(raw["time_tube"])
    if "time_predict" not in raw and "time_identify" in raw:  # before the C++ controller: inside time_identify
        raw["time_predict"] = np.zeros_like(raw["time_identify"])
    for name, shape in _ACTUATION_ARRAYS.items():  # a record from before the actuator model: ideal, not recorded
        if name not in raw and "u" in raw:
            raw[name] = np.zeros((len(raw["u"]), *shape))
    missing = [f.name for f in RunRecord.array_fields() if f.name not in raw]
    if missing:
        raise ValueError(f"{path}: not a run record (missing arrays {missing})")
    arrays = {f.name: np.asarray(raw[f.name], dtype=np.float64) for f in RunRecord.array_fields()}
    meta = raw["metadata"]
    record = RunRecord(
        method=raw["method"],
        seed=-1 if raw["seed"] is None else raw["seed"],
        **arrays,
        statuses=[str(v) for v in raw.get("status", [])],
        failures=[str(v) for v in raw.get("failure", [])],
        tube_statuses=[str(v) for v in raw.get("tube_status", [])],
        design_failures=[str(v) for v in raw.get("design_failure", [])],
        actuation_statuses=[str(v) for v in raw.get("actuation_status", [])],
        wall_time_s=float(meta.get("wall_time_s", 0.0)),
        applied=dict(meta.get("applied", {})),
        navigation=_navigation(raw),
    )
    return record, {k: raw[k] for k in ("config", "metadata", "tubempc_version")}


def _navigation(raw: dict[str, Any]) -> Any:
    from ..scenario.navigation import NavigationRecord

    return NavigationRecord.from_arrays(raw)
