"""A campaign's columnar store (Parquet): one writer (:class:`CampaignStoreWriter`) and one reader
(:class:`CampaignStore`).

A campaign folder keeps its runs in two tables under ``store/``, each a folder of Parquet files that
pandas, pyarrow or xarray read without tubempc (``pandas.read_parquet(DIR / "store" / "runs")``):

``store/runs/``: one row per run.
    ``index`` (int64), ``seed`` (int64), ``status`` ("ok" or "failed"), ``error`` and ``traceback``
    (strings of a failed run, else null), ``run_time_s`` (the run's wall time in its worker, s); then
    the run's result flattened to one column per scalar: a mapping's keys joined by ``.``, a list's
    items as ``[i]`` (``ffa.J_p``, ``ffa.terminal_error.position``, ``ffa.statuses.solved``,
    ``applied.disturbance.S_p[0][1]``, ``applied.actuators.scale_p[2]``). A null cell means the run had
    no such value (a failed run, a status it never took, an optional field it did not have, or a value
    that was None); an empty list or mapping leaves no column. Booleans stay booleans, integers int64,
    numbers float64 (exact: a float survives to the bit), strings strings.
``store/steps/``: the per-step arrays in long format, one row per (run, group, step).
    ``index`` (int64), ``group`` (string: the method), ``step`` (int32, k = 0, 1, ...), then one column
    per array and component: ``error[0]`` ... ``error[11]`` for an array of shape (T, 12), ``nav_nees``
    for one of shape (T + 1,); the dtype is the array's (float32 for a campaign's arrays). Arrays of one
    group may differ in length: a shorter one's cells past its end are null (and only those).

Both tables are written in part files ``part-<seq>-L<level>.parquet``, each written to a temporary
name and renamed into place, the steps part before the runs part of the same name: a run is in the
store once its row is in a runs part, and a steps part without its runs part (a write interrupted
between the two) is removed when the store is next opened for writing. Parts of level 0 are the batches
written as runs finish; when ``merge_parts`` parts of a level exist they are merged into one part of
the next level, and :meth:`CampaignStoreWriter.close` merges everything into one part per table (a
campaign of 10^5 runs ends as two files). A run that is written again (a failed run re-run) has
several rows until a merge: the reader takes an "ok" row over a "failed" one, then the newest part.

While a campaign runs, its parts may differ in columns (a status only later runs took): read it then with
:class:`CampaignStore`, which unifies them (pandas and pyarrow take the first part's columns); at its end
there is one part per table.

Every part keeps ``tubempc.store_format`` (:data:`STORE_FORMAT`) in its Parquet metadata. Campaign
folders written before the store (``runs/run_<i>.json`` and ``runs/run_<i>.npz``) are refused by the
reader with the command that converts them (:func:`convert_legacy_campaign`, ``tubempc campaign
convert DIR``), the only reader of that layout.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import shutil
import struct
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from .. import __version__

__all__ = [
    "BASE_COLUMNS",
    "STORE_DIR",
    "STORE_FORMAT",
    "CampaignStore",
    "CampaignStoreWriter",
    "LegacyCampaignError",
    "RunOutput",
    "RunRow",
    "convert_legacy_campaign",
    "differing_columns",
    "differing_steps",
    "flatten",
    "is_legacy_campaign",
    "unflatten",
]

#: Format of the store's tables (in each part's Parquet metadata ``tubempc.store_format``).
STORE_FORMAT = 1
#: The store's folder inside a campaign folder.
STORE_DIR = "store"
#: The runs table's own columns (before the flattened result).
BASE_COLUMNS = ("index", "seed", "status", "error", "traceback", "run_time_s")
_STEP_KEYS = ("index", "group", "step")
_PART = re.compile(r"^part-(\d{8})-L(\d+)\.parquet$")
_KEY = re.compile(r"^[^.\[\]]+$")
_INT64 = (-(2**63), 2**63 - 1)

Scalar = bool | int | float | str | None


@dataclass(frozen=True)
class RunOutput:
    """What a campaign's run function returns: ``result`` (nested mappings and lists of scalars, the
    runs table's columns) and ``steps`` (per group, e.g. per method, arrays whose first axis is the
    step: the steps table)."""

    result: Mapping[str, Any]
    steps: Mapping[str, Mapping[str, npt.NDArray[Any]]] = field(default_factory=dict)


@dataclass(frozen=True)
class RunRow:
    """One finished run as the writer takes it: ``output`` for a run that returned, ``error`` and
    ``traceback`` for one that raised."""

    index: int
    seed: int
    ok: bool
    run_time_s: float
    output: RunOutput | None = None
    error: str | None = None
    traceback: str | None = None


# --- flattening -------------------------------------------------------------------------------------


def _scalar(value: Any, path: str) -> Scalar:
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        v = int(value)
        if not _INT64[0] <= v <= _INT64[1]:
            raise ValueError(f"store column {path!r}: integer {v} outside int64")
        return v
    if isinstance(value, float | np.floating):
        return float(value)
    raise ValueError(f"store column {path!r}: a {type(value).__name__} is not a number, string, boolean or None")


def flatten(value: Any, prefix: str = "") -> dict[str, Scalar]:
    """``value`` (mappings with string keys, lists, tuples and arrays of scalars) as one entry per scalar,
    named by its path: mapping keys joined by ``.``, list items as ``[i]`` (the module docstring). A key
    holding ``.``, ``[`` or ``]`` is a ValueError naming it."""
    out: dict[str, Scalar] = {}

    def walk(v: Any, path: str) -> None:
        t = type(v)
        if t is float or t is str or t is bool or v is None:
            if not path:
                raise ValueError("store: a run's result must be a mapping")
            out[path] = v
        elif t is dict or (t is not list and t is not tuple and t is not np.ndarray and isinstance(v, Mapping)):
            for k, item in v.items():
                if type(k) is not str or not _KEY.match(k):
                    raise ValueError(f"store column {path!r}: key {k!r} must be a non-empty string without '.', '[', ']'")
                walk(item, f"{path}.{k}" if path else k)
        elif t is list or t is tuple or t is np.ndarray:
            if not path:
                raise ValueError("store: a run's result must be a mapping, not a list")
            for i, item in enumerate(v.tolist() if t is np.ndarray else v):
                walk(item, f"{path}[{i}]")
        else:
            if not path:
                raise ValueError("store: a run's result must be a mapping")
            out[path] = _scalar(v, path)

    walk(value, prefix)
    return out


_TOKEN = re.compile(r"\.?([^.\[\]]+)|\[(\d+)\]")


def _tokens(path: str) -> list[str | int]:
    out: list[str | int] = []
    pos = 0
    while pos < len(path):
        m = _TOKEN.match(path, pos)
        if m is None:
            raise ValueError(f"store column {path!r}: not a flattened path")
        out.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        pos = m.end()
    return out


def unflatten(flat: Mapping[str, Scalar]) -> dict[str, Any]:
    """The nested mappings and lists of :func:`flatten`'s entries (those that are None left out: a null
    cell is an absent value)."""
    root: dict[str, Any] = {}
    for path, value in flat.items():
        if value is None:
            continue
        toks = _tokens(path)
        node: Any = root
        for tok, nxt in itertools.pairwise(toks):
            empty: Any = [] if isinstance(nxt, int) else {}
            if isinstance(tok, int):
                while len(node) <= tok:
                    node.append(None)
                if node[tok] is None:
                    node[tok] = empty
                node = node[tok]
            else:
                node = node.setdefault(tok, empty)
        last = toks[-1]
        if isinstance(last, int):
            while len(node) <= last:
                node.append(None)
            node[last] = value
        else:
            node[last] = value
    return root


# --- types ------------------------------------------------------------------------------------------


_SCALAR_TYPES = {bool: pa.bool_(), int: pa.int64(), float: pa.float64(), str: pa.string(), type(None): pa.null()}


def _column_type(name: str, values: Iterable[Scalar]) -> pa.DataType:
    kinds = {type(v) for v in values if v is not None}
    if not kinds:
        return pa.null()
    if kinds == {bool}:
        return pa.bool_()
    if kinds == {int}:
        return pa.int64()
    if kinds <= {int, float}:
        return pa.float64()
    if kinds == {str}:
        return pa.string()
    raise ValueError(f"store column {name!r}: values of mixed types {sorted(k.__name__ for k in kinds)}")


def _unify(name: str, a: pa.DataType, b: pa.DataType) -> pa.DataType:
    if a == b or pa.types.is_null(b):
        return a
    if pa.types.is_null(a):
        return b
    numeric = (pa.int64(), pa.float64(), pa.float32(), pa.int32())
    if a in numeric and b in numeric:
        return pa.float64()
    raise ValueError(f"store column {name!r}: type {a} in one part, {b} in another")


def _unified_schema(schemas: Iterable[pa.Schema], first: tuple[str, ...]) -> pa.Schema:
    types: dict[str, pa.DataType] = {}
    for s in schemas:
        for f in s:
            types[f.name] = _unify(f.name, types[f.name], f.type) if f.name in types else f.type
    names = [n for n in first if n in types] + [n for n in types if n not in first]
    return pa.schema([(n, types[n]) for n in names])


def _conform(table: pa.Table, schema: pa.Schema) -> pa.Table:
    cols = []
    for f in schema:
        if f.name in table.column_names:
            c = table.column(f.name)
            cols.append(c if c.type == f.type else c.cast(f.type))
        else:
            cols.append(pa.nulls(table.num_rows, f.type))
    return pa.Table.from_arrays(cols, schema=schema)


# --- building a batch's tables ----------------------------------------------------------------------


def _flat_row(r: RunRow) -> dict[str, Scalar]:
    """A run's row of the runs table: its own columns and its flattened result."""
    f: dict[str, Scalar] = {
        "index": int(r.index),
        "seed": int(r.seed),
        "status": "ok" if r.ok else "failed",
        "error": r.error,
        "traceback": r.traceback,
        "run_time_s": float(r.run_time_s),
    }
    if r.output is not None:
        result = flatten(r.output.result)
        clash = set(result) & set(BASE_COLUMNS)
        if clash:
            raise ValueError(f"store: a run's result may not hold the runs table's own columns {sorted(clash)}")
        f.update(result)
    return f


def _runs_table(flat: list[dict[str, Scalar]]) -> pa.Table:
    names: dict[str, None] = dict.fromkeys(BASE_COLUMNS)
    for f in flat:
        names.update(dict.fromkeys(f))
    arrays, fields = [], []
    for n in names:
        values = [f.get(n) for f in flat]
        t = _EMPTY_RUNS[n] if n in _EMPTY_RUNS else _column_type(n, values)
        if t == pa.float64():
            values = [None if v is None else float(v) for v in values]
        arrays.append(pa.array(values, type=t))
        fields.append(pa.field(n, t))
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


def _steps_table(rows: list[RunRow]) -> pa.Table | None:
    """The steps table of a batch: each array gathered over the batch's runs and groups into one numpy
    array (a cell past the end of a run's array, or of an array a run lacks, is null), split into its
    columns and made Arrow arrays once."""
    blocks: list[tuple[int, str, int, dict[str, npt.NDArray[Any]]]] = []  # (index, group, rows, arrays)
    kinds: dict[str, tuple[tuple[int, ...], np.dtype[Any]]] = {}  # name -> (component shape, dtype)
    for r in rows:
        if r.output is None:
            continue
        for group, arrays in r.output.steps.items():
            if not arrays:
                continue
            if not _KEY.match(group):
                raise ValueError(f"store: step group {group!r} must be a non-empty string without '.', '[', ']'")
            got: dict[str, npt.NDArray[Any]] = {}
            for name, a in arrays.items():
                arr = np.asarray(a)
                if arr.ndim < 1 or not _KEY.match(name) or name in _STEP_KEYS:
                    raise ValueError(f"store: step array {group}.{name} must be named plainly and have a step axis")
                if arr.dtype.kind not in "fiub":
                    raise ValueError(f"store: step array {group}.{name} has dtype {arr.dtype} (numbers only)")
                shape, dtype = arr.shape[1:], arr.dtype
                if name in kinds:
                    have_shape, have_dtype = kinds[name]
                    if have_shape != shape:
                        raise ValueError(f"store: step array {group}.{name} of shape {shape} per step, {have_shape} before")
                    dtype = np.result_type(have_dtype, dtype)
                kinds[name] = (shape, dtype)
                got[name] = arr
            blocks.append((r.index, group, max(len(v) for v in got.values()), got))
    if not blocks:
        return None
    total = sum(n for _, _, n, _ in blocks)
    out: dict[str, pa.Array] = {
        "index": pa.array(np.concatenate([np.full(n, i, dtype=np.int64) for i, _, n, _ in blocks])),
        "group": pa.DictionaryArray.from_arrays(
            pa.array(np.concatenate([np.full(n, k, dtype=np.int32) for k, (_, _, n, _) in enumerate(blocks)])),
            pa.array([g for _, g, _, _ in blocks], type=pa.string()),
        ).cast(pa.string()),
        "step": pa.array(np.concatenate([np.arange(n, dtype=np.int32) for _, _, n, _ in blocks])),
    }
    for name, (shape, dtype) in kinds.items():
        values = np.zeros((total, *shape), dtype=dtype)
        valid = np.zeros(total, dtype=bool)
        at = 0
        for _, _, n, arrays in blocks:
            part = arrays.get(name)
            if part is not None:
                values[at : at + len(part)] = part
                valid[at : at + len(part)] = True
            at += n
        mask = None if valid.all() else ~valid
        flat = values.reshape(total, -1)
        for j, idx in enumerate(np.ndindex(*shape)):
            col = name + "".join(f"[{i}]" for i in idx)
            out[col] = pa.array(flat[:, j] if shape else values, mask=mask)
    return pa.table(out)


# --- files ------------------------------------------------------------------------------------------


@dataclass(frozen=True, order=True)
class _Part:
    seq: int
    level: int

    @property
    def name(self) -> str:
        return f"part-{self.seq:08d}-L{self.level}.parquet"


def _parts(folder: Path) -> list[_Part]:
    if not folder.is_dir():
        return []
    out = []
    for p in folder.iterdir():
        m = _PART.match(p.name)
        if m:
            out.append(_Part(int(m.group(1)), int(m.group(2))))
    return sorted(out)


def _write_parquet(table: pa.Table, path: Path, level: int) -> None:
    """``table`` to ``path`` atomically (a temporary file renamed), floats byte-stream split and zstd."""
    meta = {b"tubempc.store_format": str(STORE_FORMAT).encode(), b"tubempc.version": __version__.encode()}
    table = table.replace_schema_metadata({**(table.schema.metadata or {}), **meta, b"tubempc.level": str(level).encode()})
    floats = [f.name for f in table.schema if pa.types.is_floating(f.type)]
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    pq.write_table(
        table,
        tmp,
        compression="zstd",
        use_dictionary=[f.name for f in table.schema if pa.types.is_string(f.type)],
        use_byte_stream_split=floats or False,
        row_group_size=1 << 17,
    )
    os.replace(tmp, path)


def _read_part(path: Path) -> pa.Table:
    table = pq.read_table(path)
    fmt = (table.schema.metadata or {}).get(b"tubempc.store_format")
    if fmt is None or int(fmt) > STORE_FORMAT:
        raise ValueError(f"{path}: store format {fmt!r} is not one this tubempc reads (1-{STORE_FORMAT})")
    return table.replace_schema_metadata(None)


def _winners(runs: pa.Table, part_order: pa.Array) -> pa.Table:
    """The row of each run index: an "ok" row over a "failed" one, then the newest part (``part_order``:
    the part's rank per row), sorted by index."""
    ok = pc.equal(runs.column("status"), "ok").fill_null(False).cast(pa.int8())
    keyed = runs.append_column("__ok", ok).append_column("__part", part_order)
    order = keyed.sort_by([("index", "ascending"), ("__ok", "descending"), ("__part", "descending")])
    idx = order.column("index").to_numpy()
    first = np.ones(len(idx), dtype=bool)
    first[1:] = idx[1:] != idx[:-1]
    return order.filter(pa.array(first))


# --- the writer -------------------------------------------------------------------------------------


class CampaignStoreWriter:
    """Appends finished runs to the store of campaign folder ``folder`` (the module docstring).

    Runs are buffered and written as one part when ``flush_runs`` are waiting or ``flush_seconds`` have
    passed since the last write (0: every run at once); :meth:`flush` writes them now. ``merge_parts``
    parts of one level are merged into one of the next. :meth:`close` (also on leaving a ``with``
    block) writes what is buffered and merges the store into one part per table."""

    def __init__(
        self,
        folder: str | Path,
        *,
        flush_runs: int = 1000,
        flush_seconds: float = 10.0,
        merge_parts: int = 16,
        _converting: bool = False,
    ) -> None:
        if flush_runs < 1 or flush_seconds < 0 or merge_parts < 2:
            raise ValueError(
                f"store writer: flush_runs >= 1, flush_seconds >= 0 and merge_parts >= 2, got {flush_runs}, "
                f"{flush_seconds}, {merge_parts}"
            )
        root = Path(folder)
        if is_legacy_campaign(root) and not _converting:
            raise LegacyCampaignError(root)
        self.runs_dir = root / STORE_DIR / "runs"
        self.steps_dir = root / STORE_DIR / "steps"
        self.runs_dir.mkdir(parents=True, exist_ok=True)
        self.steps_dir.mkdir(parents=True, exist_ok=True)
        for d in (self.runs_dir, self.steps_dir):
            for p in d.glob(".part-*.tmp"):  # a write interrupted before its rename
                p.unlink()
        committed = set(_parts(self.runs_dir))
        for part in _parts(self.steps_dir):
            if part not in committed:  # its runs part was never written: the runs were not stored
                (self.steps_dir / part.name).unlink()
        self.flush_runs, self.flush_seconds, self.merge_parts = flush_runs, flush_seconds, merge_parts
        self._buffer: list[tuple[RunRow, dict[str, Scalar]]] = []
        self._last = time.monotonic()
        self._seq = max((p.seq for p in committed), default=-1)
        # the runs table's column types so far (every part's and the buffer's): a run is checked against
        # them when it is added, so that no part written can conflict with another
        self._types: dict[str, pa.DataType] = {}
        for part in committed:
            for f in pq.read_schema(self.runs_dir / part.name):
                self._types[f.name] = _unify(f.name, self._types[f.name], f.type) if f.name in self._types else f.type

    def __enter__(self) -> CampaignStoreWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close(merge=exc[0] is None)

    def add(self, row: RunRow) -> None:
        """Buffers a finished run (written with the next part). A result that cannot be stored (a value
        that is not a scalar, a bad key, a column of another type than the store's) is a ValueError
        naming the column, and the run is not buffered."""
        flat = _flat_row(row)
        new: dict[str, pa.DataType] = {}
        for name, value in flat.items():
            t = _EMPTY_RUNS[name] if name in _EMPTY_RUNS else _SCALAR_TYPES[type(value)]
            have = self._types.get(name)
            if have is None or have != t:
                new[name] = t if have is None else _unify(name, have, t)
        self._types.update(new)
        self._buffer.append((row, flat))
        if len(self._buffer) >= self.flush_runs or time.monotonic() - self._last >= self.flush_seconds:
            self.flush()

    def flush(self) -> None:
        """Writes the buffered runs as one part (steps first, then runs: the commit) and merges levels."""
        self._last = time.monotonic()
        if not self._buffer:
            return
        buffered = sorted(self._buffer, key=lambda rf: rf[0].index)
        runs = _runs_table([f for _, f in buffered])
        steps = _steps_table([r for r, _ in buffered])
        self._seq += 1
        part = _Part(self._seq, 0)
        if steps is not None:
            _write_parquet(steps, self.steps_dir / part.name, 0)
        _write_parquet(runs, self.runs_dir / part.name, 0)
        self._buffer.clear()
        self._merge_levels()

    def _merge_levels(self) -> None:
        while True:
            parts = _parts(self.runs_dir)
            levels = sorted({p.level for p in parts})
            full = [lv for lv in levels if sum(p.level == lv for p in parts) >= self.merge_parts]
            if not full:
                return
            lv = full[0]
            self._merge([p for p in parts if p.level == lv], lv + 1)

    def _merge(self, parts: list[_Part], level: int) -> None:
        """Merges ``parts`` (all the parts of one level, or all) into one part of ``level`` named by their
        newest sequence number; the runs' winners only, sorted by index."""
        target = _Part(max(p.seq for p in parts), level)
        if parts == [target]:
            return
        runs_tables = [_read_part(self.runs_dir / p.name) for p in parts]
        schema = _unified_schema((t.schema for t in runs_tables), BASE_COLUMNS)
        rank = [np.full(t.num_rows, i, dtype=np.int64) for i, t in enumerate(runs_tables)]
        merged = pa.concat_tables([_conform(t, schema) for t in runs_tables])
        winners = _winners(merged, pa.array(np.concatenate(rank)))
        keep_by_part = {
            i: winners.filter(pc.equal(winners.column("__part"), i)).column("index").to_numpy() for i in range(len(parts))
        }
        runs = winners.drop_columns(["__ok", "__part"])
        step_schemas, step_paths = [], []
        for i, p in enumerate(parts):
            path = self.steps_dir / p.name
            if path.exists():
                step_schemas.append(pq.read_schema(path))
                step_paths.append((i, path))
        if step_paths:
            schema_s = _unified_schema(step_schemas, _STEP_KEYS).with_metadata(None)
            tmp = self.steps_dir / f".{target.name}.{os.getpid()}.tmp"
            floats = [f.name for f in schema_s if pa.types.is_floating(f.type)]
            meta = {
                b"tubempc.store_format": str(STORE_FORMAT).encode(),
                b"tubempc.version": __version__.encode(),
                b"tubempc.level": str(level).encode(),
            }
            with pq.ParquetWriter(
                tmp,
                schema_s.with_metadata(meta),
                compression="zstd",
                use_dictionary=["group"],
                use_byte_stream_split=floats or False,
            ) as w:
                for i, path in step_paths:  # one part in memory at a time
                    t = _read_part(path)
                    t = t.filter(pc.is_in(t.column("index"), pa.array(keep_by_part[i])))
                    if t.num_rows:
                        w.write_table(_conform(t, schema_s).replace_schema_metadata(meta))
            os.replace(tmp, self.steps_dir / target.name)
        _write_parquet(runs, self.runs_dir / target.name, level)
        for p in parts:  # runs parts first: a steps part is never left without its runs part
            if p != target:
                (self.runs_dir / p.name).unlink(missing_ok=True)
        for p in parts:
            if p != target:
                (self.steps_dir / p.name).unlink(missing_ok=True)

    def compact(self) -> None:
        """Merges every part into one part per table."""
        parts = _parts(self.runs_dir)
        if len(parts) > 1:
            self._merge(parts, max(p.level for p in parts) + 1)

    def close(self, merge: bool = True) -> None:
        """Writes the buffered runs and (``merge``) merges the store into one part per table."""
        self.flush()
        if merge:
            self.compact()


# --- the reader -------------------------------------------------------------------------------------


class LegacyCampaignError(ValueError):
    """A campaign folder in the layout before the store (runs/run_<i>.json and .npz)."""

    def __init__(self, folder: Path) -> None:
        super().__init__(
            f"{folder}: a campaign written before the columnar store (runs/run_<i>.json and runs/run_<i>.npz); "
            f"convert it with `tubempc campaign convert {folder}` (one Parquet store in {folder / STORE_DIR}, "
            "the old files removed), then rerun the command"
        )


def is_legacy_campaign(folder: Path) -> bool:
    """Whether ``folder`` holds runs in the layout before the store."""
    runs = folder / "runs"
    return runs.is_dir() and any(runs.glob("run_*.json"))


class CampaignStore:
    """The store of campaign folder ``folder`` as it is on disk when opened (the module docstring).

    A folder in the layout before the store is a :class:`LegacyCampaignError`."""

    def __init__(self, folder: str | Path, *, _converting: bool = False) -> None:
        self.folder = Path(folder)
        if is_legacy_campaign(self.folder) and not _converting:
            raise LegacyCampaignError(self.folder)
        self.runs_dir = self.folder / STORE_DIR / "runs"
        self.steps_dir = self.folder / STORE_DIR / "steps"
        self._parts = _parts(self.runs_dir)
        self._runs: pa.Table | None = None
        self._part_of: dict[int, int] = {}

    @property
    def exists(self) -> bool:
        """Whether any run is stored."""
        return bool(self._parts)

    def runs(self) -> pa.Table:
        """The runs table: one row per run index (the winner of its rows), sorted by index."""
        if self._runs is None:
            if not self._parts:
                self._runs = pa.table({c: pa.array([], type=t) for c, t in _EMPTY_RUNS.items()})
                return self._runs
            tables = [_read_part(self.runs_dir / p.name) for p in self._parts]
            schema = _unified_schema((t.schema for t in tables), BASE_COLUMNS)
            rank = np.concatenate([np.full(t.num_rows, i, dtype=np.int64) for i, t in enumerate(tables)])
            winners = _winners(pa.concat_tables([_conform(t, schema) for t in tables]), pa.array(rank))
            self._part_of = dict(zip(winners.column("index").to_pylist(), winners.column("__part").to_pylist(), strict=True))
            self._runs = winners.drop_columns(["__ok", "__part"])
        return self._runs

    def indices(self, status: str | None = None) -> list[int]:
        """The stored run indices (``status`` "ok" or "failed": those only)."""
        runs = self.runs()
        if status is not None:
            runs = runs.filter(pc.equal(runs.column("status"), status))
        return [int(i) for i in runs.column("index").to_pylist()]

    def failures(self) -> dict[int, str]:
        """The failed runs' errors by index."""
        runs = self.runs().filter(pc.equal(self.runs().column("status"), "failed"))
        return dict(zip(runs.column("index").to_pylist(), runs.column("error").to_pylist(), strict=True))

    def row(self, index: int) -> dict[str, Scalar]:
        """Run ``index``'s row: every column (null cells as None). A ValueError if it is not stored."""
        runs = self.runs()
        hit = runs.filter(pc.equal(runs.column("index"), int(index)))
        if hit.num_rows == 0:
            raise ValueError(f"{self.runs_dir}: no run {index} in the campaign's store")
        return {k: v[0] for k, v in hit.to_pydict().items()}

    def result(self, index: int) -> dict[str, Any]:
        """Run ``index``'s result as the run function returned it (:func:`unflatten` of its columns;
        null cells absent)."""
        row = self.row(index)
        return unflatten({k: v for k, v in row.items() if k not in BASE_COLUMNS})

    def column(self, name: str, status: str | None = "ok") -> npt.NDArray[Any]:
        """One column of the runs table over the runs of ``status`` (None: all), in index order, as a
        numpy array (null as NaN for numbers)."""
        runs = self.runs()
        if status is not None:
            runs = runs.filter(pc.equal(runs.column("status"), status))
        if name not in runs.column_names:
            raise KeyError(name)
        col = runs.column(name)
        if pa.types.is_integer(col.type) or pa.types.is_floating(col.type) or pa.types.is_boolean(col.type):
            # safe=False: integers beyond 2^53 (a seed) round to the nearest double instead of failing the cast
            return np.asarray(col.cast(pa.float64(), safe=False).to_numpy(zero_copy_only=False), dtype=float)
        return np.asarray(col.to_pylist(), dtype=object)

    def iter_steps(self, group: str, columns: list[str] | None = None) -> Iterator[pa.Table]:
        """The steps table of ``group`` (its rows of the runs' winning parts), one table per part file;
        ``columns``: those only (with ``index`` and ``step``)."""
        self.runs()
        for rank, part in enumerate(self._parts):
            path = self.steps_dir / part.name
            if not path.exists():
                continue
            names = None if columns is None else ["index", "group", "step", *columns]
            if names is not None:
                have = set(pq.read_schema(path).names)
                names = [n for n in names if n in have]
            t = pq.read_table(path, columns=names, filters=[("group", "=", group)]).replace_schema_metadata(None)
            mine = [i for i, r in self._part_of.items() if r == rank]
            t = t.filter(pc.is_in(t.column("index"), pa.array(mine, type=pa.int64())))
            if t.num_rows:
                yield t

    def stacked_steps(self, group: str, name: str) -> tuple[npt.NDArray[np.int64], npt.NDArray[Any]]:
        """Array ``name`` of ``group`` over every run that has it: the runs' indices (ascending) and the
        arrays stacked, (runs, steps, ...); a ValueError when the runs' arrays differ in length."""
        cols: list[str] = []
        for part in self._parts:
            path = self.steps_dir / part.name
            if path.exists():
                cols = [c for c in pq.read_schema(path).names if c == name or c.startswith(f"{name}[")]
                if cols:
                    break
        chunks = [t for t in self.iter_steps(group, cols) if cols] if cols else []
        if not chunks:
            return np.zeros(0, dtype=np.int64), np.zeros((0, 0))
        t = pa.concat_tables(chunks)
        t = t.filter(pc.is_valid(t.column(cols[0]))).sort_by([("index", "ascending"), ("step", "ascending")])
        idx, counts = np.unique(t.column("index").to_numpy(), return_counts=True)
        if len(set(counts.tolist())) > 1:
            raise ValueError(
                f"{self.steps_dir}: {group}.{name} has runs of different lengths {sorted(set(counts.tolist()))}"
            )
        arrays = _arrays_of(t.select(["index", "group", "step", *cols]))
        a = arrays[name]
        return idx.astype(np.int64), a.reshape(len(idx), int(counts[0]), *a.shape[1:])

    def steps(self, index: int) -> dict[str, dict[str, npt.NDArray[Any]]]:
        """Run ``index``'s per-step arrays by group and name, as the run function returned them (shape and
        dtype)."""
        self.row(index)
        rank = self._part_of[int(index)]
        path = self.steps_dir / self._parts[rank].name
        if not path.exists():
            return {}
        t = pq.read_table(path, filters=[("index", "=", int(index))]).replace_schema_metadata(None)
        out: dict[str, dict[str, npt.NDArray[Any]]] = {}
        for group in sorted(set(t.column("group").to_pylist())):
            g = t.filter(pc.equal(t.column("group"), group)).sort_by("step")
            out[group] = _arrays_of(g)
        return out


_EMPTY_RUNS = {
    "index": pa.int64(),
    "seed": pa.int64(),
    "status": pa.string(),
    "error": pa.string(),
    "traceback": pa.string(),
    "run_time_s": pa.float64(),
}


def _arrays_of(t: pa.Table) -> dict[str, npt.NDArray[Any]]:
    """A group's rows of one run (sorted by step) as its arrays: the columns ``name`` or ``name[i]...``
    gathered by name, each cut where its nulls begin (all-null columns: arrays that run did not have)."""
    cols: dict[str, list[tuple[tuple[int, ...], Any]]] = {}
    for name in t.column_names:
        if name in _STEP_KEYS:
            continue
        toks = _tokens(name)
        cols.setdefault(str(toks[0]), []).append((tuple(int(x) for x in toks[1:]), t.column(name)))
    out: dict[str, npt.NDArray[Any]] = {}
    for name, parts in cols.items():
        valid = [c.length() - c.null_count for _, c in parts]
        n = max(valid)
        if n == 0:
            continue
        shape = tuple(max(idx[d] for idx, _ in parts) + 1 for d in range(len(parts[0][0])))
        dtype = parts[0][1].type.to_pandas_dtype()
        a = np.zeros((n, *shape), dtype=dtype)
        for idx, c in parts:
            where: tuple[slice | int, ...] = (slice(None), *idx)
            a[where] = c.slice(0, n).to_numpy(zero_copy_only=False)
        out[name] = a
    return out


# --- comparisons to the bit -------------------------------------------------------------------------


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, int) and not isinstance(a, bool) and isinstance(b, float):
        a = float(a)  # an integer stored in a column that another part made float64
    if isinstance(b, int) and not isinstance(b, bool) and isinstance(a, float):
        b = float(b)
    if isinstance(a, float) and isinstance(b, float):
        return struct.pack("<d", a) == struct.pack("<d", b)
    return type(a) is type(b) and a == b


def differing_columns(row: Mapping[str, Scalar], flat: Mapping[str, Scalar], ignore: Iterable[str] = ()) -> list[str]:
    """The columns of a stored run's ``row`` (:meth:`CampaignStore.row`) whose value is not that of
    ``flat`` (:func:`flatten` of a result), to the bit (a null cell equals an absent entry); the runs
    table's own columns and those named in ``ignore`` or ending in one of them (``run_time_s``) are
    not compared."""
    skip = tuple(ignore)
    names = (set(row) | set(flat)) - set(BASE_COLUMNS)
    out = []
    for n in sorted(names):
        if any(n == s or n.endswith(f".{s}") for s in skip):
            continue
        if not _same(row.get(n), flat.get(n)):
            out.append(n)
    return out


def differing_steps(
    stored: Mapping[str, Mapping[str, npt.NDArray[Any]]], steps: Mapping[str, Mapping[str, npt.NDArray[Any]]]
) -> list[str]:
    """The step arrays (``<group>.<name>``) of a stored run (:meth:`CampaignStore.steps`) that are not
    those of ``steps``: missing on either side, or another dtype, shape or bytes."""
    out = []
    for g in sorted(set(stored) | set(steps)):
        a, b = stored.get(g, {}), steps.get(g, {})
        for n in sorted(set(a) | set(b)):
            x, y = a.get(n), b.get(n)
            if x is None or y is None:
                out.append(f"{g}.{n} (missing)" if x is None else f"{g}.{n} (not flown)")
                continue
            y = np.asarray(y)
            if x.dtype != y.dtype or x.shape != y.shape or x.tobytes() != y.tobytes():
                out.append(f"{g}.{n}")
    return out


# --- the layout before the store --------------------------------------------------------------------


def convert_legacy_campaign(folder: str | Path, *, steps_groups: Iterable[str] | None = None) -> int:
    """Converts a campaign folder of the layout before the store (``runs/run_<i>.json``, ``.failed.json``
    and ``.npz``) into the store, checks every run reads back equal, then removes ``runs/``; returns the
    number of runs converted. The npz's arrays ``<group>_<name>`` become the group's step arrays (the
    groups: ``steps_groups``, default the methods of the runs' results); an array without a step axis
    (``<method>_nav_touchdown_error``) becomes the result's ``nav_touchdown_error.<method>``."""
    root = Path(folder)
    runs_dir = root / "runs"
    if not is_legacy_campaign(root):
        raise ValueError(f"{root}: no runs/run_<i>.json to convert")
    if (root / STORE_DIR / "runs").is_dir() and _parts(root / STORE_DIR / "runs"):
        raise ValueError(f"{root / STORE_DIR}: the folder already has a store; remove one of the two")
    rows: list[RunRow] = []
    for path in sorted(runs_dir.glob("run_*.json")):
        m = re.match(r"^run_(\d+)(\.failed)?\.json$", path.name)
        if m is None:
            continue
        index = int(m.group(1))
        ok_path = runs_dir / f"run_{m.group(1)}.json"
        if m.group(2) and ok_path.exists():
            continue  # re-run since: the ok record stands
        rec = json.loads(path.read_text(encoding="utf-8"))
        if not rec.get("ok"):
            rows.append(RunRow(index, int(rec["seed"]), False, math.nan, None, rec.get("error"), rec.get("traceback")))
            continue
        result = dict(rec["result"])
        groups = [g for g in (steps_groups or result) if g != "applied"]
        steps: dict[str, dict[str, npt.NDArray[Any]]] = {}
        npz = path.with_suffix(".npz")
        if npz.exists():
            with np.load(npz, allow_pickle=False) as d:
                for key in d.files:
                    group = next((g for g in groups if key.startswith(f"{g}_")), None)
                    if group is None:
                        raise ValueError(f"{npz}: array {key!r} of no method of the run ({groups})")
                    name, a = key[len(group) + 1 :], d[key]
                    if name == "nav_touchdown_error":
                        result.setdefault("nav_touchdown_error", {})[group] = a
                    else:
                        steps.setdefault(group, {})[name] = a
        run_time = sum(float(v.get("run_time_s", 0.0)) for k, v in rec["result"].items() if k != "applied")
        rows.append(RunRow(index, int(rec["seed"]), True, run_time, RunOutput(result, steps)))
    with CampaignStoreWriter(root, flush_runs=len(rows) + 1, flush_seconds=math.inf, _converting=True) as w:
        for r in rows:
            w.add(r)
    store = CampaignStore(root, _converting=True)
    for r in rows:  # the store reads back every run, to the bit
        if r.output is None:
            continue
        differ = differing_columns(store.row(r.index), flatten(r.output.result))
        differ += differing_steps(store.steps(r.index), r.output.steps)
        if differ:
            raise ValueError(f"{root}: run {r.index} does not read back from the store ({differ}); the old files are kept")
    shutil.rmtree(runs_dir)
    return len(rows)
