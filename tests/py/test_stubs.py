"""tools/check_stubs.py: the hand-kept stubs declare what tubempc._core binds, and the check sees drift."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

from tubempc import _core

ROOT = Path(__file__).resolve().parents[2]


def _checker() -> ModuleType:
    spec = importlib.util.spec_from_file_location("check_stubs", ROOT / "tools" / "check_stubs.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_stub_matches_the_module() -> None:
    assert _checker().main(ROOT / "python" / "tubempc") == 0


def test_the_check_reports_a_missing_and_an_extra_member() -> None:
    check = _checker()
    stub = (ROOT / "python" / "tubempc" / "_mpc.pyi").read_text()
    assert check.differences(_core.mpc, stub, "_mpc.pyi") == []
    missing = stub.replace("    scp_mode: ScpMode\n", "", 1)
    assert check.differences(_core.mpc, missing, "_mpc.pyi") == ["_mpc.pyi: Settings.scp_mode is bound but not in the stub"]
    extra = stub.replace("    scp_mode: ScpMode\n", "    scp_mode: ScpMode\n    scp_modes: int\n", 1)
    assert check.differences(_core.mpc, extra, "_mpc.pyi") == ["_mpc.pyi: Settings.scp_modes is in the stub but not bound"]
    no_class = stub.replace("class ScpMode(_OptionNames, enum.Enum):", "class ScpModes(_OptionNames, enum.Enum):", 1)
    assert check.differences(_core.mpc, no_class, "_mpc.pyi") == [
        "_mpc.pyi: ScpMode is bound but not in the stub",
        "_mpc.pyi: ScpModes is in the stub but not bound",
    ]


def test_field_and_enum_lines_are_generated_from_the_tables(tmp_path: Path) -> None:
    check = _checker()
    stub = (ROOT / "python" / "tubempc" / "_mpc.pyi").read_text()
    assert check.with_generated_fields(_core.mpc, stub) == stub
    # a field line dropped, or of the wrong type, is written back as the table says
    for edited in (
        stub.replace("    scp_mode: ScpMode\n", "", 1),
        stub.replace("    horizon: int\n", "    horizon: float\n", 1),
        stub.replace("    RealTime = ...\n", "", 1),  # an enum member, from its name table
    ):
        assert edited != stub
        assert check.with_generated_fields(_core.mpc, edited) == stub
    # the lint fails on such a stub; --write repairs it
    for f in (ROOT / "python" / "tubempc").glob("_*.pyi"):
        (tmp_path / f.name).write_text(f.read_text())
    (tmp_path / "_mpc.pyi").write_text(stub.replace("    horizon: int\n", "", 1))
    assert check.main(tmp_path) == 1
    assert check.main(tmp_path, write=True) == 0
    assert (tmp_path / "_mpc.pyi").read_text() == stub
    assert check.main(tmp_path) == 0
