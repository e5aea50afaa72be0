"""Checks that the hand-kept stubs python/tubempc/_<area>.pyi declare the names tubempc._core binds.

For each submodule tubempc._core.<area>: every public function and class the module has is in the
stub and every one the stub declares is in the module; the same for each class's public members
(a stub class also has the members of the stub classes it derives from). Run by tools/lint.sh after
the module is built; exit status 1 with the differences (docs/decisions.md "One field table").
Usage: python tools/check_stubs.py [stub directory]
"""

from __future__ import annotations

import ast
import sys
import types
from pathlib import Path

STUBS = Path(__file__).resolve().parents[1] / "python" / "tubempc"
# Members every pybind11 enum has and enum.Enum declares.
_ENUM_MEMBERS = frozenset({"name", "value"})


def _public(name: str) -> bool:
    return not name.startswith("_")


def _body_names(body: list[ast.stmt]) -> set[str]:
    names: set[str] = set()
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.Assign):
            names.update(t.id for t in node.targets if isinstance(t, ast.Name))
    return names


def _classes(tree: ast.Module, stub_dir: Path) -> dict[str, ast.ClassDef]:
    """The stub's classes, and those it imports from a sibling stub (`from ._mpc import _OptionNames`)."""
    out: dict[str, ast.ClassDef] = {}
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module is not None:
            other = ast.parse((stub_dir / f"{node.module}.pyi").read_text())
            imported = {a.name for a in node.names}
            out.update({n.name: n for n in other.body if isinstance(n, ast.ClassDef) and n.name in imported})
    out.update({n.name: n for n in tree.body if isinstance(n, ast.ClassDef)})
    return out


def _class_members(cls: ast.ClassDef, classes: dict[str, ast.ClassDef]) -> set[str]:
    names = _body_names(cls.body)
    for base in cls.bases:
        if isinstance(base, ast.Name) and base.id in classes:
            names |= _class_members(classes[base.id], classes)
    return names


def differences(module: types.ModuleType, stub_source: str, label: str, stub_dir: Path = STUBS) -> list[str]:
    """The names bound in `module` and not declared in the stub, and the other way round."""
    tree = ast.parse(stub_source)
    classes = _classes(tree, stub_dir)
    local = {n.name for n in tree.body if isinstance(n, ast.ClassDef)}
    declared = {n for n in _body_names(tree.body) if _public(n) and n != "__all__"}
    bound = {n for n in dir(module) if _public(n) and not isinstance(getattr(module, n), types.ModuleType)}
    out = [f"{label}: {n} is bound but not in the stub" for n in sorted(bound - declared)]
    out += [f"{label}: {n} is in the stub but not bound" for n in sorted(declared - bound)]
    for name in sorted(bound & declared & local):
        cls = getattr(module, name)
        if not isinstance(cls, type):
            continue
        stub = _class_members(classes[name], classes)
        own = {n for n in vars(cls) if _public(n)}
        if hasattr(cls, "__members__"):  # a pybind11 enum
            own -= _ENUM_MEMBERS
        out += [f"{label}: {name}.{n} is bound but not in the stub" for n in sorted(own - stub)]
        out += [
            f"{label}: {name}.{n} is in the stub but not bound"
            for n in sorted(_body_names(classes[name].body))
            if _public(n) and not hasattr(cls, n)
        ]
    return out


def main(stub_dir: Path) -> int:
    from tubempc import _core

    problems: list[str] = []
    for area in sorted(n for n in dir(_core) if isinstance(getattr(_core, n), types.ModuleType)):
        stub = stub_dir / f"_{area}.pyi"
        if not stub.exists():
            problems.append(f"_core.{area}: no stub {stub}")
            continue
        problems += differences(getattr(_core, area), stub.read_text(), stub.name, stub_dir)
    for p in problems:
        print(p, file=sys.stderr)
    if not problems:
        print("stubs match tubempc._core")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else STUBS))
