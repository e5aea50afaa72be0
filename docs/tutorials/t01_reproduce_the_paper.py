"""
Reproduce the paper
===================

One closed-loop run of TBMPC and TBMPC-FFA on the paper's Bennu landing (the default scenario), a
short Monte Carlo campaign of both methods, and the report. The command line does the same:
``tubempc run``, ``tubempc montecarlo --runs 100`` and ``tubempc report DIR``.
"""

# %%
# One run of both methods
# -----------------------
# :func:`tubempc.config.load_config` with no argument is the packaged paper scenario
# (``tubempc/data/bennu_paper.toml``: every number of the paper, and the project's readings where it
# is ambiguous). :func:`tubempc.analysis.runner.run_methods` flies each method with disturbance seed 0 and
# writes the run records, the summary and the figures.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from tubempc.analysis import montecarlo
from tubempc.analysis.report import write_report
from tubempc.analysis.runner import run_methods
from tubempc.config import load_config
from tubempc.results import load_record

work = Path(tempfile.mkdtemp(prefix="tubempc_tutorial1_"))
cfg = load_config()
summary = run_methods(cfg, ["tbmpc", "ffa"], 0, work / "run", progress=False, cache_dir=work / "cache")
for method, s in summary.methods.items():
    print(
        f"{method:6s} J_p = {s.J_p:.4g}, J_r = {s.J_r:.4g}, terminal position error "
        f"{1e3 * s.terminal_error.position:.2f} mm, steps outside the tube {s.steps_outside_tube}"
    )
assert summary.comparison is not None  # both methods flown
print(f"TBMPC-FFA's J_p is {summary.comparison.J_p_reduction_percent:.1f} % below TBMPC's (paper: about 90 %)")

# %%
# The tube, step by step
# ----------------------
# The run record (:class:`tubempc.results.RunRecord`) holds every array with its unit. The tube
# excursion is e^T Pe^-1 e of the error one step after the plan: at most 1 while the state stays in
# the tube (paper Proposition 1). TBMPC flies the tube designed from the prior; TBMPC-FFA's follows
# the identified disturbance.
fig, ax = plt.subplots(figsize=(7, 3.2))
for method in ("tbmpc", "ffa"):
    rec, _ = load_record(work / "run" / f"{method}.h5")
    ax.plot(rec.t[:-1], rec.excursion[:, 0], label=f"{method}: translation")
    ax.plot(rec.t[:-1], rec.excursion[:, 1], "--", label=f"{method}: rotation")
ax.axhline(1.0, color="k", lw=0.8)
ax.set_xlabel("t (s)")
ax.set_ylabel("tube excursion (1)")
ax.legend(fontsize=7, ncol=2)
fig.tight_layout()

# %%
# A Monte Carlo campaign
# ----------------------
# Each run draws its own disturbance seed from the master seed; the campaign is resumable and its
# store keeps every run's metrics and the dispersions it applied, one row per run, and the per-step
# arrays (``tubempc run --from-campaign DIR --index I`` flies one again). The paper's Table 4 uses 100
# runs; four keep this page quick. The summary bounds each failure kind's probability
# (Clopper-Pearson: with 0 of 4 runs failing, below 1 - 0.05^(1/4) = 53 % at 95 % confidence).
mc = montecarlo(cfg, 4, work / "montecarlo", master_seed=0, workers=2, progress=False)
for method, row in mc.methods.items():
    print(
        f"{method:6s} J_p mean {row.J_p.mean:.4g} (3 sigma {row.J_p.three_sigma:.2g}), "
        f"runs outside the tube {row.runs_outside_tube}/{mc.runs}"
    )
assert mc.statistics is not None
for method, ms in mc.statistics.methods.items():
    exit_bound = ms.failures["tube_exit"]
    print(f"{method:6s} tube exit: {exit_bound.failures} of {exit_bound.runs} runs, < {exit_bound.upper_bound:.2g}")
print(f"campaign: {mc.wall_time_s:.1f} s on {mc.workers} workers")

# %%
# The campaign's store, read with pandas alone: one row per run.
import pandas as pd  # noqa: E402

runs = pd.read_parquet(work / "montecarlo" / "store" / "runs")
print(runs[["index", "seed", "ffa.J_p", "applied.realised_disturbance.std[0]"]])

# %%
# The report
# ----------
# One self-contained HTML file (figures embedded) and its Markdown twin, from a results folder. The
# HTML carries an interactive 3D view of the mission (plotly, inlined: it opens offline): the
# asteroid and the glide-slope cone at t_f, the reference and both trajectories, the translational
# tubes at true scale and the site. The test suite opens it in headless Chromium; its screenshot:
#
# .. image:: /img/view3d.png
#    :alt: the report's 3D view of the default mission
#    :width: 100%
html, md = write_report(work / "run")
print(f"{html.name}: {html.stat().st_size / 1e6:.1f} MB; {md.name}: {len(md.read_text().splitlines())} lines")
print(np.round([summary.methods[m].J_p for m in ("tbmpc", "ffa")], 4))
