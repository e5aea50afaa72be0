"""Scenario set-up (room 3 of docs/layout.md): from a configuration to everything a run flies with.

- :mod:`.build`: :func:`build_scenario` and the :class:`Scenario` it returns (models, boundary states,
  input bounds, checks);
- :mod:`.shapes` and :mod:`.bodies`: shape files and generated bodies;
- :mod:`.sites`: sites, normals and terminal states on the rotating body;
- :mod:`.reference`: the reference trajectory (sequential convex programming);
- :mod:`.actuators` and :mod:`.navigation`: the actuator presets and the navigation set-up, built into
  the C++ objects that fly.

The names of :mod:`.build` (the module this package replaced) are attributes of the package.
"""

from __future__ import annotations

from typing import Any

from ..compat import package_attribute


def __getattr__(name: str) -> Any:
    return package_attribute(__name__, f"{__name__}.build", name)
