"""Results folders that re-open anywhere: the shape file a configuration names is copied into the
folder (``shape/<name>.<sha256 prefix><ext>``) and the folder's ``config.toml`` names that copy,
relative to itself, so that ``tubempc run --config DIR/config.toml``, ``tubempc report DIR`` and
``tubempc run --from-campaign DIR`` work after the folder is moved or copied to another machine. The
copy's sha256 is kept in the folder's ``summary.json`` / ``campaign.json`` and checked on re-flight.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from ..config import Config, ConfigError

__all__ = ["SHAPE_FOLDER", "file_sha256", "pin_config", "shape_file", "shape_record"]

#: Sub-folder of a results folder holding the copy of its shape file.
SHAPE_FOLDER = "shape"


def file_sha256(path: Path) -> str:
    """sha256 (hex) of a file's bytes."""
    h = hashlib.sha256()
    with path.open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def shape_file(cfg: Config) -> Path | None:
    """The shape file a configuration names (None for the generated body), resolved as
    :func:`tubempc.scenario.scenario_shape` resolves it."""
    from ..scenario.build import config_folder

    if cfg.asteroid.shape == "generated":
        return None
    path = Path(cfg.asteroid.shape)
    return path if path.is_absolute() else config_folder(cfg) / path


def shape_record(cfg: Config) -> dict[str, Any] | None:
    """{"file": the configuration's shape path, "sha256": its content's} (None: the generated body)."""
    path = shape_file(cfg)
    if path is None:
        return None
    return {"file": cfg.asteroid.shape, "unit": cfg.asteroid.shape_unit, "sha256": file_sha256(path)}


def pin_config(cfg: Config, out: Path) -> Config:
    """The configuration as the results folder ``out`` keeps it (the caller saves it as
    ``out/config.toml``): with a shape file, the file is copied to ``out/shape/`` and the returned
    configuration names the copy relative to ``out`` (its source is ``out/config.toml``); with the
    generated body, ``cfg`` itself. ConfigError if the shape file cannot be read (naming
    ``asteroid.shape``)."""
    out.mkdir(parents=True, exist_ok=True)
    path = shape_file(cfg)
    if path is None:
        return cfg
    try:
        sha = file_sha256(path)
    except OSError as exc:
        raise ConfigError(f"{cfg.source}: asteroid.shape: {path}: cannot read the shape file ({exc.strerror})") from exc
    name = f"{path.stem}.{sha[:16]}{path.suffix}"
    dest = out / SHAPE_FOLDER / name
    if not (dest.exists() and file_sha256(dest) == sha):
        dest.parent.mkdir(exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=dest.parent, prefix=f".{name}.", suffix=".tmp")
        os.close(fd)
        shutil.copyfile(path, tmp)
        os.replace(tmp, dest)
    pinned = cfg.with_overrides({"asteroid.shape": f"{SHAPE_FOLDER}/{name}"})
    return dataclasses.replace(pinned, source=str(out / "config.toml"))
