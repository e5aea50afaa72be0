"""Analysis (room 7 of docs/layout.md): metrics, the paper's claims, campaigns, figures and reports.

- :mod:`.metrics`: J_p, J_r, tube excursions, convergence fits (paper Eq. 54-55);
- :mod:`.runner`: ``tubempc run`` (both methods, summary, figures);
- :mod:`.campaign` and :mod:`.studies`: resumable seeded campaigns, the Monte Carlo and the
  forgetting-factor sweep;
- :mod:`.statistics`: a campaign's failure bounds, percentiles, worst runs and drivers;
- :mod:`.claims`: the paper's claims checked against results folders;
- :mod:`.figures`, :mod:`.view3d` and :mod:`.report`: figures, the 3D view and the HTML/Markdown report.

The names of :mod:`.studies` (the module ``tubempc.analysis`` was before) are attributes of the package.
"""

from __future__ import annotations

from typing import Any

from ..compat import package_attribute


def __getattr__(name: str) -> Any:
    return package_attribute(__name__, f"{__name__}.studies", name)
