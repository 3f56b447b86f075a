"""Issue 33: the HTML page shows every figure the report wrote, from where it is.

Kept apart from the report's own test files (another change is under way there).
"""

from __future__ import annotations

import re

from benchmarks.cli.main import main


def test_every_figure_of_a_report_is_an_image_of_the_page_that_exists(tmp_path):
    # Oracle: the folder itself.  The page's <img> sources are exactly the PNGs the report wrote
    # (relative names beside index.html), and each is a PNG file there.
    assert main(["bench", "run", "smoke", "--limit", "2", "--workers", "1", "--out", str(tmp_path)]) == 0
    report = tmp_path / "report"
    page = (report / "index.html").read_text()
    srcs = re.findall(r'<img src="([^"]+)"', page)
    pngs = sorted(p.name for p in report.glob("*.png"))
    assert pngs and sorted(srcs) == pngs
    for src in srcs:
        assert (report / src).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # and no figure link fell back to text (an unsafe or absolute source is shown as text)
    assert not re.search(r"<p>!\[", page)
