"""Package layout rules: the rooms of docs/layout.md (each imports only the floors below it and itself,
with no circle, in Python and in C++), the old import paths of tubempc.compat, and no module importing
a private name of another (exceptions: the compiled extension `_core` and its type stubs
(`_dynamics.pyi`, ...: a stub with no module beside it), and dunders such as `__version__`)."""

from __future__ import annotations

import ast
import re
import warnings
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet
from packaging.version import Version

import tubempc

PACKAGE = Path(tubempc.__file__).parent
ROOT = Path(__file__).resolve().parents[2]


LAYOUT = ROOT / "docs" / "layout.md"


def _floors(heading: str) -> dict[str, int]:
    """The table under ``heading`` of docs/layout.md: room (its code name) -> floor."""
    text = LAYOUT.read_text(encoding="utf-8").split(heading, 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| (\d+) \| `([\w.]+)` \|", text, flags=re.M)
    assert rows, f"no table under {heading!r} in {LAYOUT}"
    return {room: int(floor) for floor, room in rows}


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every tubempc module ``path`` imports, at any depth of the file (a function's
    imports and those under TYPE_CHECKING count: a circle through them is still a circle)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if not module.startswith("tubempc"):
                continue
            for alias in node.names:  # `from . import x` imports the module x where there is one
                sub = f"{module}.{alias.name}"
                found.append((node.lineno, sub if _is_module(sub) else module))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.startswith("tubempc")]
    return [(line, m) for line, m in found if m != name]


def _is_module(name: str) -> bool:
    rel = Path(*name.split(".")[1:])
    return (PACKAGE / rel).with_suffix(".py").exists() or (PACKAGE / rel / "__init__.py").exists() or name.endswith("._core")


def _room(module: str, floors: dict[str, int]) -> str | None:
    """The room of a module: the longest room name that is the module or a package above it (the
    type stubs of the compiled core's areas, ``tubempc._dynamics`` for ``tubempc._core.dynamics``, are
    the core's)."""
    stub = re.fullmatch(r"tubempc\.(_\w+)", module)
    if stub and (PACKAGE / f"{stub.group(1)}.pyi").exists() and not (PACKAGE / f"{stub.group(1)}.py").exists():
        return "tubempc._core"
    rooms = [r for r in floors if module == r or module.startswith(r + ".")]
    return max(rooms, key=len) if rooms else None


def _graph() -> dict[str, list[tuple[int, str]]]:
    return {_module_name(p): _imports(p) for p in sorted(PACKAGE.rglob("*.py"))}


def _arrow_violations(graph: dict[str, list[tuple[int, str]]], floors: dict[str, int]) -> list[str]:
    bad = []
    for module, imported in graph.items():
        room = _room(module, floors)
        if module == "tubempc":
            continue  # the package's entry: it names the rooms' public names (imported lazily)
        assert room is not None, f"{module} is in no room of docs/layout.md"
        for line, target in imported:
            to = _room(target, floors) if target != "tubempc" else "tubempc._core"  # `from tubempc import _core`
            assert to is not None, f"{module}:{line} imports {target}, which is in no room of docs/layout.md"
            if to != room and floors[to] >= floors[room]:
                bad.append(f"{module}:{line} ({room}, floor {floors[room]}) imports {target} ({to}, floor {floors[to]})")
    return bad


def _circles(graph: dict[str, list[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, []):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_every_import_follows_the_floors_of_the_layout() -> None:
    assert _arrow_violations(_graph(), _floors("## The Python package")) == []


def test_no_import_circle() -> None:
    graph = {m: [t for _, t in imported] for m, imported in _graph().items() if m != "tubempc"}
    assert _circles(graph) == []


def test_the_layout_checks_see_a_wrong_arrow_and_a_circle() -> None:
    floors = _floors("## The Python package")
    graph = {
        "tubempc.scenario.build": [(3, "tubempc.design.library"), (4, "tubempc.config")],
        "tubempc.design.library": [(5, "tubempc.scenario.build")],
    }
    bad = _arrow_violations(graph, floors)
    assert len(bad) == 1 and bad[0].startswith("tubempc.scenario.build:3 (tubempc.scenario, floor 3)")
    circles = _circles({m: [t for _, t in imported] for m, imported in graph.items()})
    assert circles == [["tubempc.design.library", "tubempc.scenario.build"]]


def _cpp_includes() -> list[tuple[str, str, str]]:
    """(file, its area, the included area) of every #include "tubempc/<area>/..." under cpp/."""
    found = []
    for path in sorted((ROOT / "cpp").rglob("*.[ch]pp")):
        area = path.relative_to(ROOT / "cpp").parts[2 if path.parts[-4:-2][0] == "include" else 1]
        for target in re.findall(r'#include "tubempc/(\w+)/', path.read_text(encoding="utf-8")):
            found.append((str(path.relative_to(ROOT)), area, target))
    return found


def test_the_cpp_areas_include_only_the_floors_below() -> None:
    floors = _floors("## The C++ core")
    includes = _cpp_includes()
    assert {area for _, area, _ in includes} <= set(floors)
    bad = [f"{f} ({a}) includes {t}" for f, a, t in includes if t != a and floors[t] >= floors[a]]
    assert bad == []


def test_the_old_import_paths_work_with_a_warning() -> None:
    """Each module of tubempc.compat.MOVED_MODULES imports under its old name as the new module, with a
    DeprecationWarning that names the new path; the names that moved out of a module likewise."""
    import importlib
    import sys

    from tubempc import compat

    for old, new in compat.MOVED_MODULES.items():
        sys.modules.pop(old, None)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            module = importlib.import_module(old)
        assert module is importlib.import_module(new), old
        assert module.__spec__ is not None and module.__spec__.name == new, old  # its own spec, not the alias's
        assert any(issubclass(w.category, DeprecationWarning) and new in str(w.message) for w in caught), old
    for (module_name, name), new in compat.MOVED_NAMES.items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            value = getattr(importlib.import_module(module_name), name)
        assert value is getattr(importlib.import_module(new), name)
        assert any(issubclass(w.category, DeprecationWarning) for w in caught)
    # the rooms that replaced a module keep its names, without a warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert tubempc.scenario.build_scenario is tubempc.scenario.build.build_scenario
        assert tubempc.results.RunRecord is tubempc.results.records.RunRecord
        assert tubempc.analysis.montecarlo is tubempc.analysis.studies.montecarlo
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        _ = tubempc.scenario.nothing_here


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
        bad.write_text("from ..sim.closed_loop import _Plant\nfrom ._secret import helper\n", encoding="utf-8")
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
    assert tubempc.analysis.figures.__name__ == "tubempc.analysis.figures"


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
