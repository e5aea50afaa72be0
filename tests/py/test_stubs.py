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
