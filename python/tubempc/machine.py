"""Facts about the machine a benchmark ran on, printed and saved with every result."""

from __future__ import annotations

import os
import platform
from typing import Any

from ._core import build_info


def machine_info() -> dict[str, Any]:
    """CPU model, core count, Python and the core's build facts."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "core_build": build_info(),
    }
