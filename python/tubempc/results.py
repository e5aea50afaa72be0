"""Self-describing HDF5 result files: arrays, the configuration and the seed in one file.

Layout: every array is a dataset at the root (``/x``, ``/u``, ...; units in the dataset attribute
``units`` when given), and the root attributes hold ``config`` (JSON of the full configuration),
``seed``, ``method``, ``tubempc_version`` and ``metadata`` (JSON of anything else, e.g. metrics).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from . import __version__

__all__ = ["load_result", "save_result"]


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
