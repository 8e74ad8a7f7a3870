"""The main job's linearised LDR error (src/mix/estimate.rs), shared by the diagnostic tools
(`mask_error.py`, `estimator_check.py`): an error in linear light counts as its square times
the square of the paper's LDR curve's slope, 255*clamp(x,0,1)^(1/2.2), taken at a smoothed level.
"""
import numpy as np


def box(x, k):
    """Mean of each pixel's k x k neighbourhood (k odd), the border repeated: box(x, 3) is the
    job's smoothed level."""
    r = k // 2
    p = np.pad(x, ((r, r), (r, r), (0, 0)), mode="edge")
    return sum(p[dy:dy + x.shape[0], dx:dx + x.shape[1]] for dy in range(k) for dx in range(k)) / (k * k)


def slope(level):
    """The LDR curve's slope at `level`: 0 above 1 (clamped), the level floored at 1/512."""
    return np.where(level >= 1, 0.0, 255 / 2.2 * np.maximum(level, 1 / 512) ** (1 / 2.2 - 1))
