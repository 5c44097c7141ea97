"""The report on paper: headless Chromium prints the page (its @media print styles: a section a page, figures and
table rows kept whole) to PDF. Chromium because a user who reads the page has a browser, and Chromium's print lays it
out as on screen; a PDF library would need its own layout of the same page."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

from ..user_error import UserError


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def print_pdf(page: Path, pdf: Path, timeout: float = 300.0) -> Path:
    """Print the HTML page to pdf with headless Chromium (a fresh profile, nothing fetched); one line if it cannot."""
    browser = chromium()
    if browser is None:
        raise UserError(f"the report: no PDF written: headless Chromium is not installed (apt-get install chromium); "
                        f"the same report is at {page}")
    with tempfile.TemporaryDirectory(prefix="tl-print-") as profile:
        done = subprocess.run(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
             "--disable-component-update", "--no-first-run", f"--user-data-dir={profile}",
             f"--print-to-pdf={pdf}", "--no-pdf-header-footer", Path(page).resolve().as_uri()],
            stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=timeout)
    if done.returncode != 0 or not Path(pdf).is_file():
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise UserError(f"the report: Chromium wrote no PDF ({last}); the same report is at {page}")
    return Path(pdf)
