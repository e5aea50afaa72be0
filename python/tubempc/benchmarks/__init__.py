"""Rerunnable benchmarks behind ``tubempc bench NAME``.

Each module of this package is one benchmark and defines ``DESCRIPTION: str``,
``add_arguments(parser: argparse.ArgumentParser) -> None`` and ``run(args: argparse.Namespace) -> int``.
Every benchmark prints the machine it ran on and can write its figures as JSON (``--json PATH``).
"""

from __future__ import annotations

import importlib
import json
import pkgutil
from pathlib import Path
from types import ModuleType
from typing import Any

__all__ = ["available", "load", "write_json"]


def available() -> list[str]:
    """Names of the benchmarks in this package."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))


def write_json(path: str | Path | None, data: Any) -> None:
    """Writes a benchmark's figures (``--json PATH``; nothing when ``path`` is None)."""
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(data, indent=1, sort_keys=True))


def load(name: str) -> ModuleType:
    """Imports the benchmark module ``name``."""
    return importlib.import_module(f"{__name__}.{name}")
