"""The report as a reader sees it: rendered by headless Chromium, checked on the screenshot.

Skipped (with the reason) when ``/usr/bin/chromium`` is absent. The demo's session is
reported; the page must carry the pipeline's choices, units and intervals on every
coefficient and one time origin; the screenshot must be a full page of drawn figures (no
blank page, no broken image).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from station.cli import main
from tests.station.test_demo import demo_run

CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)


def screenshot(page: Path, png: Path, tmp: Path, height: int = 6500) -> None:
    """Render ``page`` with headless Chromium into ``png`` (1200 px wide)."""
    assert CHROMIUM is not None
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                    "--no-first-run", f"--user-data-dir={tmp / 'profile'}", f"--screenshot={png}",
                    f"--window-size=1200,{height}", page.resolve().as_uri()],
                   check=True, capture_output=True, timeout=120)


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt install chromium)")
def test_report_renders_with_units_choices_and_figures(tmp_path: Path) -> None:
    from PIL import Image

    demo, _ = demo_run()
    out = tmp_path / "rep"
    assert main(["report", str(demo / "session.h5"), "--out", str(out)]) == 0
    page = (out / "index.html").read_text()
    assert "Pipeline choices" in page and "refinement: <b>kept</b>" in page
    assert "95 % CI" in page and "N s/m" in page and "N/m^3" in page and page.count("± ") >= 8
    assert "time origin of every figure: the trigger" in page
    png = tmp_path / "page.png"
    screenshot(out / "index.html", png, tmp_path)
    img = np.asarray(Image.open(png).convert("L"), dtype=float)
    assert img.shape == (6500, 1200)
    # every figure drew: the page holds plenty of non-white pixels down to the last figure
    rows = np.nonzero((img < 200).sum(axis=1) > 20)[0]
    assert rows.size > 2000 and rows.max() > 4000
    # the CWT maps (dark viridis) are on the page
    assert (img < 60).sum() > 50_000
