"""The commands of ``tubempc`` (:mod:`tubempc.cli`), one plug-in each, as the benchmarks are.

Each module of this package is one command (module ``make_body`` is ``tubempc make-body``) and defines
``DESCRIPTION: str`` (its line in ``tubempc -h``), ``add_arguments(parser: argparse.ArgumentParser) ->
None`` and ``run(args: argparse.Namespace) -> int`` (the exit status). A command imports what it flies
with only when it runs (the command line starts at once). This module holds what the commands share:
the exit statuses (:mod:`tubempc.cli`'s docstring says what each means) and the option types.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..config import Config

__all__ = [
    "EXIT_ABORTED",
    "EXIT_FAILED_RUNS",
    "EXIT_GUARANTEE_LOST",
    "EXIT_INPUT",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_REFLIGHT_DIFFERS",
    "EXIT_USAGE",
    "available",
    "config_from_args",
    "guarantee_status",
    "load",
    "parse_floats",
    "parse_ints",
    "parse_seed",
    "plant_line",
    "scenario_arguments",
]

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INPUT = 0, 1, 2, 3
EXIT_GUARANTEE_LOST, EXIT_FAILED_RUNS, EXIT_REFLIGHT_DIFFERS, EXIT_INTERRUPTED = 4, 5, 6, 130
EXIT_ABORTED = 7


def available() -> list[str]:
    """The commands' names (``make-body`` for module ``make_body``)."""
    return sorted(m.name.replace("_", "-") for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))


def load(name: str) -> ModuleType:
    """Imports the module of command ``name``."""
    return importlib.import_module(f"{__name__}.{name.replace('-', '_')}")


def config_from_args(args: argparse.Namespace) -> Config:
    """The configuration of --config FILE or --scenario NAME (default: the paper's), with --shape-unit."""
    from ..config import load_config

    cfg = load_config(getattr(args, "config", None), scenario=getattr(args, "scenario", None))
    if getattr(args, "plant", None) is not None:
        cfg = cfg.with_overrides({"simulation.plant": args.plant})
    if getattr(args, "shape_unit", None) and getattr(args, "shape", None) is None:
        cfg = cfg.with_overrides({"asteroid.shape_unit": args.shape_unit})
    return cfg


def plant_line(plant: str | None) -> str:
    """Who propagated the truth, for the console: the project's plant, or Basilisk and its version."""
    if plant == "basilisk":
        from ..sim.basilisk import basilisk_version

        return f"Basilisk {basilisk_version()} (simulation.plant = basilisk)"
    if plant is None:
        return "the project's (recorded before simulation.plant)"
    return "the project's (simulation.plant = project)"


def scenario_arguments(p: argparse.ArgumentParser, *, plant: bool = True) -> None:
    """--config, --scenario and --shape-unit (and --plant, for the commands that fly)."""
    group = p.add_mutually_exclusive_group()
    group.add_argument("--config", help="scenario TOML (fields left out are the paper scenario's)")
    group.add_argument("--scenario", help="a packaged scenario by name (see 'tubempc scenarios'; default: bennu-paper)")
    p.add_argument(
        "--shape-unit",
        choices=["km", "m"],
        help="unit of the coordinates of --shape (required with it), else of the config's shape file",
    )
    if plant:
        p.add_argument(
            "--plant",
            help="who propagates the truth (simulation.plant, checked with the configuration; default: the config's): "
            "project (the C++ propagator) or basilisk (pip install 'tubempc[basilisk]')",
        )


def guarantee_status(lost: dict[str, list[str]], aborts: dict[str, str] | None = None) -> int:
    """EXIT_GUARANTEE_LOST (said on stderr) if any run lost a guarantee, else EXIT_ABORTED (said on stderr) if a run
    aborted safely (``aborts``: what aborted, and why and when), else EXIT_OK."""
    if not lost:
        if aborts:
            what = "; ".join(f"{name}: {why}" for name, why in aborts.items())
            print(f"aborted safely, {what}: exit status {EXIT_ABORTED}", file=sys.stderr)
            return EXIT_ABORTED
        return EXIT_OK
    what = "; ".join(f"{name}: {', '.join(reasons)}" for name, reasons in lost.items())
    print(f"robustness guarantee lost by {what}: exit status {EXIT_GUARANTEE_LOST}", file=sys.stderr)
    return EXIT_GUARANTEE_LOST


def parse_floats(text: str) -> list[float]:
    """Comma-separated numbers."""
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc


def parse_seed(text: str) -> int:
    """A non-negative integer."""
    try:
        value = int(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from exc
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def parse_ints(text: str) -> list[int]:
    """Comma-separated integers."""
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from exc
