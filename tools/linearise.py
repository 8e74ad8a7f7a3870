"""The main job's linearised LDR error (src/mix/estimate.rs), shared by the diagnostic tools
(`mask_error.py`, `estimator_check.py`, `importance_gain.py`): an error in linear light counts
as its square times the square of the paper's LDR curve's slope, 255*clamp(x,0,1)^(1/2.2), taken
at a smoothed level; and the EXR reader they share.
"""
import os
import sys

import numpy as np
import OpenImageIO as oiio


def channels(path, names):
    """The named channels of an EXR as an (h, w, len(names)) array; a missing file or channel ends
    the calling tool with a one-line error naming it."""
    tool = os.path.basename(sys.argv[0])
    buf = oiio.ImageBuf(path)
    if buf.has_error:
        sys.exit(f"{tool}: {path}: {buf.geterror()}")
    have = list(buf.spec().channelnames)
    missing = [n for n in names if n not in have]
    if missing:
        sys.exit(f"{tool}: {path}: no channel {missing[0]}")
    px = buf.get_pixels(oiio.FLOAT)
    return np.stack([px[:, :, have.index(n)] for n in names], -1)


def box(x, k):
    """Mean of each pixel's k x k neighbourhood (k odd), the border repeated: box(x, 3) is the
    job's smoothed level."""
    r = k // 2
    p = np.pad(x, ((r, r), (r, r), (0, 0)), mode="edge")
    return sum(p[dy:dy + x.shape[0], dx:dx + x.shape[1]] for dy in range(k) for dx in range(k)) / (k * k)


def slope(level):
    """The LDR curve's slope at `level`: 0 above 1 (clamped), the level floored at 1/512."""
    return np.where(level >= 1, 0.0, 255 / 2.2 * np.maximum(level, 1 / 512) ** (1 / 2.2 - 1))
