"""Shared test helpers: a PNG was written, has the size asked, and is not blank."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

#: The least standard deviation of a drawn image's grey levels (0..1): text, lines and fills vary
#: them; a blank or single-colour image has ~0.
NOT_BLANK = 0.05


def check_png(path: str | os.PathLike[str], size: tuple[int, int] | None = None, *,
              least: tuple[int, int] | None = None) -> Any:
    """The image at `path` (its pixels, rows x columns x channels), checked: `size` exactly as
    (rows, columns), or at least `least`; its colours not all the same."""
    import matplotlib.image as mpimg

    pixels = np.asarray(mpimg.imread(os.fspath(path)))
    if size is not None:
        assert pixels.shape[:2] == tuple(size), (pixels.shape, size)
    if least is not None:
        assert pixels.shape[0] >= least[0] and pixels.shape[1] >= least[1], (pixels.shape, least)
    colours = pixels[..., :3] if pixels.ndim == 3 else pixels
    assert float(colours.std()) > NOT_BLANK, f"{path} is blank"
    return pixels
