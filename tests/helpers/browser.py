"""The Chromium the browser tests drive (Playwright's Python driver), and canvas pixels.

The distribution's Chromium (``apt-get install chromium``; ``chromium`` or ``chromium-browser`` on
the path, or the executable ``$VIBRA_CHROMIUM`` names), else one Playwright installed itself
(``playwright install chromium``); None where there is none (the tests skip, saying so).
"""

from __future__ import annotations

import io
import os
import shutil
from pathlib import Path

import numpy as np
from PIL import Image
from playwright.sync_api import sync_playwright

SKIP_REASON = ("no Chromium executable: neither chromium nor chromium-browser on the path, $VIBRA_CHROMIUM unset, "
               "and no browser of Playwright's own (apt-get install chromium)")


def _playwrights_chromium() -> str | None:
    """The Chromium that ``playwright install chromium`` downloaded, if it did."""
    with sync_playwright() as driver:
        path = driver.chromium.executable_path
    return path if Path(path).is_file() else None


def chromium() -> str | None:
    """The Chromium executable to drive, or None."""
    return (os.environ.get("VIBRA_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
            or _playwrights_chromium())


def pixels(png: bytes) -> np.ndarray:
    """(height, width, 3) int16 RGB values of a PNG (a canvas screenshot)."""
    with Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGB"), dtype=np.int16)
