"""Package layout rules: no module imports a private name of another. Exceptions: the compiled
extension `_core` and its type stubs (`_dynamics.pyi`, ...: a stub with no module beside it), and
dunders such as `__version__`."""

from __future__ import annotations

import ast
from pathlib import Path

from packaging.specifiers import SpecifierSet
from packaging.version import Version

import tubempc

PACKAGE = Path(tubempc.__file__).parent
ROOT = Path(__file__).resolve().parents[2]


def _private(name: str) -> bool:
    if not name.startswith("_") or (name.startswith("__") and name.endswith("__")) or name == "_core":
        return False
    stub_only = (PACKAGE / f"{name}.pyi").exists() and not (PACKAGE / f"{name}.py").exists()
    return not stub_only


def _private_imports(path: Path) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level == 0 and not module.startswith("tubempc"):
                continue  # third-party
            for alias in node.names:
                private_module = any(_private(p) for p in module.split("."))
                if _private(alias.name) or private_module:
                    found.append(
                        f"{path.relative_to(PACKAGE)}:{node.lineno}: from {'.' * node.level}{module} import {alias.name}"
                    )
    return found


def test_no_module_imports_a_private_name_of_another() -> None:
    offenders = [hit for path in sorted(PACKAGE.rglob("*.py")) for hit in _private_imports(path)]
    assert offenders == []


def test_the_checker_sees_a_private_import(tmp_path: Path) -> None:
    bad = PACKAGE / "benchmarks" / "__layout_probe__.py"
    try:
        bad.write_text("from ..closed_loop import _Plant\nfrom ._secret import helper\n", encoding="utf-8")
        hits = _private_imports(bad)
    finally:
        bad.unlink()
    assert len(hits) == 2 and "_Plant" in hits[0] and "_secret" in hits[1]


def test_import_and_version_load_no_heavy_dependency() -> None:
    """`import tubempc` and `tubempc --version` load the compiled core only (the command line starts at once)."""
    import subprocess
    import sys

    probe = (
        "import sys, tubempc, tubempc.cli\n"
        "tubempc.cli.build_parser()\n"
        "heavy = [m for m in ('cvxpy', 'pint', 'matplotlib', 'scipy', 'h5py', 'trimesh') if m in sys.modules]\n"
        "print(','.join(heavy))"
    )
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=60)
    assert r.stdout.strip() == ""
    # every public name still resolves (lazily)
    missing = [n for n in tubempc.__all__ if not hasattr(tubempc, n)]
    assert missing == []
    assert tubempc.figures.__name__ == "tubempc.figures"


def _upper(specifiers: SpecifierSet) -> tuple[Version, bool] | None:
    """The highest version a specifier set admits (version, inclusive), None if unbounded above."""
    best: tuple[Version, bool] | None = None
    for spec in specifiers:
        if spec.operator in ("<=", "==", "<", "~="):
            bound = (Version(spec.version.removesuffix(".*")), spec.operator != "<")
            if best is None or bound < best:
                best = bound
    return best


def test_pip_install_and_the_test_extra_agree_on_the_shared_dependencies() -> None:
    """Every package that `pip install .` installs and the test extra's bsk caps is capped by tubempc at
    or below bsk's cap: installing the test extra downgrades nothing (issue #28)."""
    import importlib.metadata
    import tomllib

    import pytest
    from packaging.requirements import Requirement

    try:
        bsk = [Requirement(r) for r in importlib.metadata.requires("bsk") or []]
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("bsk (the test extra) is not installed")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    ours = {Requirement(r).name.lower(): Requirement(r) for r in project["dependencies"]}
    checked = []
    for req in bsk:
        if req.marker is not None and not req.marker.evaluate({"extra": ""}):
            continue
        name = req.name.lower()
        theirs = _upper(req.specifier)
        if name not in ours or theirs is None:
            continue
        mine = _upper(ours[name].specifier)
        assert mine is not None and mine <= theirs, (name, str(ours[name]), str(req))
        checked.append(name)
    assert {"numpy", "matplotlib", "pillow", "tqdm"} <= set(checked)
