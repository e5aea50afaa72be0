"""Facts about the machine a benchmark ran on, printed and saved with every result."""

from __future__ import annotations

import datetime
import os
import platform
import shlex
import sys
from typing import Any

from .._core import build_info


def machine_info() -> dict[str, Any]:
    """CPU model, core count, Python, the core's build facts, the date (UTC) and the command line."""
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
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "command": "tubempc " + shlex.join(sys.argv[1:])
        if sys.argv and sys.argv[0].endswith(("tubempc", "__main__.py"))
        else shlex.join(sys.argv),
    }
