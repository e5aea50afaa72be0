"""``tubempc scenarios``: the packaged scenarios."""

from __future__ import annotations

import argparse

DESCRIPTION = "list the packaged scenarios"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    del parser  # no options


def run(_: argparse.Namespace) -> int:
    import importlib.resources

    from ..config import SCENARIOS

    root = importlib.resources.files("tubempc").joinpath("data")
    for name, (file, about) in SCENARIOS.items():
        print(f"{name:14s} {about}\n{'':14s} {root.joinpath(*file.split('/'))}")
    print("fly one with 'tubempc run --scenario NAME'; copy its TOML to start your own (missing fields are the paper's)")
    return 0
