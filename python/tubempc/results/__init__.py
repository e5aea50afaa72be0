"""Results (room 5 of docs/layout.md): what a run or a command writes, and its one reader each.

- :mod:`.records`: :class:`RunRecord` (a run's arrays) and its HDF5 file;
- :mod:`.summaries`: the typed summary.json / sweep.json files;
- :mod:`.campaign_store`: a campaign's runs and per-step arrays (Parquet);
- :mod:`.pinning`: results folders that re-open anywhere (the shape file copied beside them);
- :mod:`.export`: scenario files for C++ programs;
- :mod:`.machine`: the machine a result was measured on.

The names of :mod:`.records` (the module this package replaced) are attributes of the package.
"""

from __future__ import annotations

from typing import Any

from ..compat import package_attribute


def __getattr__(name: str) -> Any:
    return package_attribute(__name__, f"{__name__}.records", name)
