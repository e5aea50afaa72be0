"""Checks that the stubs python/tubempc/_<area>.pyi declare the names tubempc._core binds, and writes
their generated part.

For each submodule tubempc._core.<area>: every public function and class the module has is in the
stub and every one the stub declares is in the module; the same for each class's public members
(a stub class also has the members of the stub classes it derives from). The attributes of a class
bound from a C++ field table (``bind_fields``: it has ``field_names()``) and the members of an enum
bound from a C++ name table (``bind_option_enum``, ``bind_named_enum``: it has ``names()``) are
generated, not kept by hand: one line ``name: type`` per field, in the table's order, right after the
stub's ``def field_names()``, the type that of the field's default (``bool``, ``int``, ``float``,
``str``, ``_Arr`` for a matrix, the enum's class, the class of a nested settings struct); one line
``Identifier = ...`` per enumerator.
Run by tools/lint.sh after the module is built; exit status 1 with the differences (docs/decisions.md
"One field table"); ``--write`` rewrites the generated lines instead.
Usage: python tools/check_stubs.py [--write] [stub directory]
"""

from __future__ import annotations

import ast
import sys
import types
from pathlib import Path
from typing import Any

import numpy as np

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


def _stub_type(value: Any) -> str:
    """The stub annotation of a field from its default value."""
    if isinstance(value, bool | int | float | str):
        return type(value).__name__
    if isinstance(value, np.ndarray):
        return "_Arr"
    if hasattr(type(value), "__members__"):  # a pybind11 enum
        return type(value).__name__
    if hasattr(type(value), "field_names"):  # a nested settings struct bound from its own field table
        return type(value).__name__
    raise TypeError(f"no stub type for a field of type {type(value).__name__}")


def with_generated_fields(module: types.ModuleType, stub_source: str) -> str:
    """The stub with the lines a C++ table decides generated from the module: the field lines of each
    field-table class (one with ``field_names()``), put right after ``def field_names()``, and the members
    of each enum bound from a name table (one with ``names()``), ``Identifier = ...`` in the table's
    order where its members were; the old lines removed."""
    lines = stub_source.splitlines(keepends=True)
    tree = ast.parse(stub_source)
    edits: list[tuple[int, int, list[str]]] = []  # (first line, end line) of a block to replace, 0-based
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef)):
        bound = getattr(module, cls.name, None)
        if not isinstance(bound, type) or not hasattr(bound, "field_names"):
            continue
        names = list(bound.field_names())
        default = bound()
        generated = [f"    {n}: {_stub_type(getattr(default, n))}\n" for n in names]
        anchor = next((f for f in cls.body if isinstance(f, ast.FunctionDef) and f.name == "field_names"), None)
        if anchor is None or anchor.end_lineno is None:
            raise ValueError(f"stub class {cls.name} has field_names() bound but no 'def field_names()'")
        old = [
            node.lineno - 1
            for node in cls.body
            if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.target.id in names
        ]
        edits += [(i, i + 1, []) for i in old]
        edits.append((anchor.end_lineno, anchor.end_lineno, generated))
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef)):
        bound = getattr(module, cls.name, None)
        if not isinstance(bound, type) or not hasattr(bound, "names") or not hasattr(bound, "__members__"):
            continue  # not an enum bound from a C++ name table
        members = [
            node.lineno - 1
            for node in cls.body
            if isinstance(node, ast.Assign) and all(isinstance(t, ast.Name) for t in node.targets)
        ]
        at = members[0] if members else cls.body[0].lineno - 1
        edits += [(i, i + 1, []) for i in members]
        edits.append((at, at, [f"    {name} = ...\n" for name in bound.__members__]))
    for start, end, new in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
        lines[start:end] = new
    return "".join(lines)


def main(stub_dir: Path, write: bool = False) -> int:
    from tubempc import _core

    problems: list[str] = []
    for area in sorted(n for n in dir(_core) if isinstance(getattr(_core, n), types.ModuleType)):
        stub = stub_dir / f"_{area}.pyi"
        if not stub.exists():
            problems.append(f"_core.{area}: no stub {stub}")
            continue
        module = getattr(_core, area)
        text = stub.read_text()
        generated = with_generated_fields(module, text)
        if generated != text:
            if write:
                stub.write_text(generated)
                print(f"wrote the field lines of {stub}")
            else:
                problems.append(
                    f"{stub.name}: field or enum lines differ from the C++ tables (python tools/check_stubs.py --write)"
                )
        problems += differences(module, generated if write else text, stub.name, stub_dir)
    for p in problems:
        print(p, file=sys.stderr)
    if not problems:
        print("stubs match tubempc._core")
    return 1 if problems else 0


if __name__ == "__main__":
    args = sys.argv[1:]
    write = "--write" in args
    rest = [a for a in args if a != "--write"]
    sys.exit(main(Path(rest[0]) if rest else STUBS, write))
