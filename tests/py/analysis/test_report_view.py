"""The report's interactive 3D view, opened in a real browser: headless Chromium (Debian's `chromium`,
driven by playwright without a browser download) renders it with no console or page error, and the
screenshot is not blank. TUBEMPC_VIEW3D_SCREENSHOT=PATH also writes the screenshot there (the docs'
copy: docs/img/view3d.png)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from tubempc.analysis.report import write_report
from tubempc.cli import main
from tubempc.commands import EXIT_GUARANTEE_LOST

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(CHROMIUM is None, reason="no chromium binary (Debian: apt install chromium)")
def test_the_3d_view_renders_in_chromium_without_errors(tmp_path: Path) -> None:
    sync_api = pytest.importorskip("playwright.sync_api")
    from matplotlib.image import imread

    out = tmp_path / "run"
    # the default scenario's TBMPC leaves its tube (as in the paper): exit status 4
    assert main(["run", "--out", str(out), "--quiet", "--no-figures"]) == EXIT_GUARANTEE_LOST
    html, md = write_report(out)
    text = html.read_text()
    assert 'id="mission-view"' in text and "No 3D view" not in text
    assert 'src="http' not in text  # self-contained: plotly.js is inlined, nothing is fetched
    assert "The mission in 3D" in md.read_text()

    errors: list[str] = []
    shot = tmp_path / "view3d.png"
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=CHROMIUM,
            # root in CI needs --no-sandbox; WebGL (plotly's 3D) runs on SwiftShader without a GPU
            args=["--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--ignore-gpu-blocklist"],
        )
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        page.on("console", lambda m: errors.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
        page.goto(html.as_uri())
        page.wait_for_function(
            "() => { const d = document.getElementById('mission-view');"
            " return d && d._fullLayout && d.querySelector('.gl-container canvas'); }",
            timeout=60_000,
        )
        page.wait_for_timeout(1500)  # the WebGL scene's first frames
        page.locator("#mission-view").screenshot(path=str(shot))
        browser.close()
    assert errors == []
    img = imread(shot)[..., :3]
    colours = np.unique((img.reshape(-1, 3) * 255).astype(np.uint8), axis=0)
    assert len(colours) > 200, len(colours)  # shaded mesh, lines, cone, axes: not a blank page
    centre = img[img.shape[0] // 4 : 3 * img.shape[0] // 4, img.shape[1] // 4 : 3 * img.shape[1] // 2]
    assert centre.std() > 0.05  # the scene itself is drawn (not only the legend)
    if os.environ.get("TUBEMPC_VIEW3D_SCREENSHOT"):
        shutil.copyfile(shot, os.environ["TUBEMPC_VIEW3D_SCREENSHOT"])
