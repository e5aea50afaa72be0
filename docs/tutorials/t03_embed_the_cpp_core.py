"""
Embed the C++ core
==================

Flight-like software links the C++ core directly: install its CMake package, ``find_package(tubempc)``
in your project, link ``tubempc::core``, and fly a scenario file that the Python package exports
(the shape, the reference, the tube and the MPC settings in one text file). This page runs those steps
on the build tree of this installation (``TUBEMPC_BUILD_DIR``, default ``build/test``: the test
command's).
"""

# %%
# Install the C++ package
# -----------------------
# The wheel carries the Python module only; the C++ package (headers, ``libtubempc_core``,
# ``tubempcConfig.cmake``) is the CMake component ``tubempc_cpp`` of the same build.
import os
import subprocess
import sys
import tempfile
from pathlib import Path

root = Path.cwd()
while not (root / "pyproject.toml").exists() and root != root.parent:
    root = root.parent
build = root / os.environ.get("TUBEMPC_BUILD_DIR", "build/test")
work = Path(tempfile.mkdtemp(prefix="tubempc_tutorial3_"))


def sh(*cmd: str | Path) -> str:
    """Runs a command, fails the page if it fails, returns its output."""
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed:\n{done.stdout}\n{done.stderr}")
    return done.stdout


out = sh("cmake", "--install", build, "--component", "tubempc_cpp", "--prefix", work / "prefix")
print("\n".join(line for line in out.splitlines() if "tubempcConfig" in line or "libtubempc" in line))

# %%
# Your project
# ------------
# The example ``examples/cpp/closed_loop`` is such a project: its CMakeLists.txt is all it takes.
print((root / "examples/cpp/closed_loop/CMakeLists.txt").read_text())
sh("cmake", "-S", root / "examples/cpp/closed_loop", "-B", work / "app", f"-DCMAKE_PREFIX_PATH={work / 'prefix'}")
sh("cmake", "--build", work / "app", "-j2")

# %%
# A scenario file, flown in C++ only
# ----------------------------------
# ``tubempc export-scenario`` writes the default mission's scenario (add ``--config`` for yours): the
# models, the reference and the whole controller of both methods. The program reads it with
# ``tubempc::io::read_scenario``, flies the 300 steps of TBMPC and of TBMPC-FFA with
# ``tubempc::control::Controller`` (identification, certified tube update, tube MPC) and the truth
# propagation, and prints the summary of ``tubempc run``, the step times and the heap allocations in the
# controller step (none).
sh(sys.executable, "-m", "tubempc", "export-scenario", "--out", work / "scenario")
print(sh(work / "app" / "closed_loop", work / "scenario" / "scenario.txt"))
