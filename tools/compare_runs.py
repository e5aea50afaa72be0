"""Compares two `tubempc run` folders to the bit: every array of each <method>.h5 but the wall times,
J_p and J_r of summary.json, and every other field of the summaries but the wall times. Shows that a
change of code did not change the default run's numbers (issue #29).

    python tools/compare_runs.py BEFORE_DIR AFTER_DIR     # exit status 0: identical, 1: not
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import h5py
import numpy as np

_WALL_TIMES = ("run_time_s", "step_time")


def compare(before: Path, after: Path) -> bool:
    """Prints the comparison; True when everything but the wall times is identical to the bit."""
    sa = json.loads((before / "summary.json").read_text())
    sb = json.loads((after / "summary.json").read_text())
    same = set(sa["methods"]) == set(sb["methods"])
    for m in sorted(sa["methods"]):
        for k in ("J_p", "J_r"):
            a, b = float(sa["methods"][m][k]), float(sb["methods"][m][k])
            bits = np.float64(a).tobytes() == np.float64(b).tobytes()
            same &= bits
            print(f"{m} {k}: {a!r} -> {b!r} identical to the bit: {bits}")
        with h5py.File(before / f"{m}.h5") as fa, h5py.File(after / f"{m}.h5") as fb:
            names = sorted(n for n in fa if not n.startswith("time_"))
            differ = [n for n in names if n not in fb or fa[n][()].tobytes() != fb[n][()].tobytes()]
            final = fa["x"][-1].tobytes() == fb["x"][-1].tobytes()
            same &= not differ and final
            print(f"{m}: {len(names)} arrays (wall times excluded), differing: {differ}; final state identical: {final}")
        rest_a = {k: v for k, v in sa["methods"][m].items() if k not in _WALL_TIMES}
        rest_b = {k: v for k, v in sb["methods"][m].items() if k not in _WALL_TIMES}
        same &= rest_a == rest_b
        print(f"{m}: every other summary field equal: {rest_a == rest_b}")
    print("identical" if same else "DIFFERENT")
    return bool(same)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(0 if compare(Path(sys.argv[1]), Path(sys.argv[2])) else 1)
