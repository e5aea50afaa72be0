"""Sphinx configuration of the tubempc documentation (built by the test command, warnings as errors:
``python -m sphinx -W -b html docs build/docs/html``)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent

project = "tubempc"
author = "the tubempc developers"
copyright = "2026, the tubempc developers"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "benchmarks/*", "tutorials/README.rst", "tutorials/*.md"]
html_theme = "furo"
html_title = "tubempc"
myst_heading_anchors = 3
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_mock_imports: list[str] = []
nitpicky = False

# The tutorials: scripts executed at every build (the test command builds the docs), their printed
# output and figures included. A tutorial that fails fails the build.
sphinx_gallery_conf = {
    "examples_dirs": "tutorials",
    "gallery_dirs": "auto_tutorials",
    "filename_pattern": r"/t\d",
    "abort_on_example_error": True,
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
}


def _doxygen(app: Any) -> None:
    """The C++ reference: Doxygen's HTML of the public headers, into the site's cpp/ folder."""
    doxygen = shutil.which("doxygen")
    if doxygen is None:
        raise RuntimeError("doxygen not found: the C++ reference is part of the documentation (apt install doxygen)")
    out = Path(app.outdir) / "cpp"
    out.mkdir(parents=True, exist_ok=True)
    config = (ROOT / "Doxyfile").read_text() + (
        f"\nOUTPUT_DIRECTORY = {out}\nHTML_OUTPUT = .\nGENERATE_HTML = YES\nINPUT = cpp/include/tubempc\n"
        "USE_MDFILE_AS_MAINPAGE =\n"
    )
    subprocess.run([doxygen, "-"], input=config, text=True, cwd=ROOT, check=True, env={**os.environ})


def setup(app: Any) -> None:
    app.connect("builder-inited", _doxygen)
