"""Command-line interface of tubempc: fly a scenario (``run``), list and make scenarios (``scenarios``,
``make-body``), analyse (``montecarlo``, ``sweep``, ``report``), export for C++ (``export-scenario``),
benchmark (``bench NAME``) and report the build (``info``, ``--version``). Every command is a plug-in
of :mod:`tubempc.commands` (one module each, as the benchmarks are).

Exit status (also in the README)::

  0  done; every run kept its robustness guarantee
  1  internal error (a bug: rerun with --debug and report the traceback)
  2  usage error (a bad option or value)
  3  input error: a configuration, shape or scenario that cannot be flown (the message names the file
     and field), or an output folder that cannot be written
  4  done, but a run lost a guarantee: steps outside the tube, fallback steps or states inside the body
     (see the summary); for every command that flies: run, montecarlo, sweep, run --from-campaign
  5  a campaign finished with failed runs (before 4)
  6  a re-flight (run --from-campaign) differs from its campaign's record (before 4)
  130  interrupted (Ctrl-C)
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import Any

from . import __version__, commands
from .commands import EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED

__all__ = ["build_parser", "entry_point", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The command line: one sub-command per plug-in of :mod:`tubempc.commands`."""
    parser = argparse.ArgumentParser(prog="tubempc", description=__doc__)
    parser.add_argument("--version", action="version", version=f"tubempc {__version__}")
    parser.add_argument("--debug", action="store_true", help="show the traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in commands.available():
        module = commands.load(name)
        p = sub.add_parser(name, help=module.DESCRIPTION)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        print("tubempc: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (ValueError, OSError) as exc:  # ConfigError, ShapeError, ScenarioError; unreadable or unwritable paths
        if args.debug:
            raise
        print(f"tubempc: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except Exception as exc:
        if args.debug:
            raise
        print(
            f"tubempc: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback)", file=sys.stderr
        )
        return EXIT_INTERNAL


def _release_semaphores() -> None:
    """Unlinks the named semaphores of this process's multiprocessing locks and queues, whose finalisers
    os._exit skips: the resource tracker then has none to report as leaked on Ctrl-C. Only the
    semaphores' finalisers run (no join of a process or thread)."""
    try:
        from multiprocessing import synchronize, util

        registry: dict[Any, Any] = getattr(util, "_finalizer_registry", {})
        for finalizer in list(registry.values()):
            if getattr(finalizer, "_callback", None) is synchronize.SemLock._cleanup:  # type: ignore[attr-defined]
                finalizer()
    except Exception:  # best effort on the way out: never turn Ctrl-C into an error
        return


def entry_point() -> None:
    """Console script: exits with main()'s status, at once on Ctrl-C (a running LMI or QP solve in a
    worker thread or the design process is not waited for; results already written stay)."""
    try:
        status = main()
    except KeyboardInterrupt:
        status = EXIT_INTERRUPTED
    policy = sys.modules.get("tubempc.design.policy")  # imported only if a run used it
    if policy is not None:
        policy.shutdown_design_worker(wait=status != EXIT_INTERRUPTED)
    if status == EXIT_INTERRUPTED:
        _release_semaphores()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


if __name__ == "__main__":
    entry_point()
