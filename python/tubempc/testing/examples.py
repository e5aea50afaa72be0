"""The C++ example programs (``examples/cpp/``) as built in this checkout, for the tests and
``tubempc bench embed`` that fly them."""

from __future__ import annotations

from pathlib import Path

__all__ = ["find_example"]

_EXAMPLE = Path("examples") / "cpp" / "closed_loop" / "closed_loop"


def find_example(explicit: Path | None) -> Path:
    """The closed_loop binary: ``explicit``, or the newest one in a build folder under the current directory."""
    if explicit is not None:
        if not explicit.is_file():
            raise FileNotFoundError(f"--example {explicit}: no such file")
        return explicit
    found = sorted(Path.cwd().glob(f"build/*/{_EXAMPLE}"), key=lambda p: p.stat().st_mtime)
    if not found:
        raise FileNotFoundError(
            "no closed_loop binary under build/*/; build it (cmake -DTUBEMPC_BUILD_EXAMPLES=ON, or "
            "cmake -S examples/cpp/closed_loop against an installed tubempc) and pass --example PATH"
        )
    return found[-1]
