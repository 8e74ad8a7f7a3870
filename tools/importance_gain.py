#!/usr/bin/env python3
"""What the LDR importance of `mixmc-mmlt --importance` should save, by its model (docs/main-job.md,
fourteenth round): MMLT's per-pixel variance is ~ B*a*I/g under the target g*Y(a*C), with
B = sum(g*a*I), and the paper's LDR MSE weighs it by the squared slope T' of 255*clamp(x,0,1)^(1/2.2)
at the pixel's value, so the error is ~ sum(g*a*I) * sum(T'^2*a*I/g). Printed: that error with
g = T' (above the clamp 1/L, as `mmlt::importance`) over that with g = 1.

    tools/.venv/bin/python tools/importance_gain.py REFERENCE.exr [MASK.exr]

Without a mask MMLT renders every light path (I: the reference's beauty, `--include-direct`); with
one (a `mixmc-mask` output, channel `alpha`, complex where alpha > 0.5) it renders alpha times the
indirect light (`indirect.*`), and the ratio is printed inside the mask, outside it and over all.
"""
import sys

import numpy as np

from linearise import channels, slope


def luminance(rgb):
    rgb = rgb.astype(np.float64)
    return (0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]).ravel()


def main(argv):
    if len(argv) not in (2, 3):
        sys.exit(__doc__)
    level = luminance(channels(argv[1], ["R", "G", "B"]))
    # g as `mmlt::importance` (above the clamp 1/L of the slope at 1, not 0), T' as the score.
    t = slope(level)
    g = np.where(level < 1.0, t, 255 / 2.2 / np.maximum(level, 1.0))
    if len(argv) == 2:
        light, alpha = np.maximum(level, 0.0), np.ones_like(level)
        parts = {"whole": np.ones_like(level, dtype=bool)}
    else:
        light = np.maximum(luminance(channels(argv[1], ["indirect.R", "indirect.G", "indirect.B"])), 0.0)
        alpha = channels(argv[2], ["alpha"])[..., 0].ravel()
        inside = alpha > 0.5
        parts = {"in-mask": inside, "outside": ~inside, "whole": np.ones_like(inside)}

    def error(weight, sel):
        spent = (weight * alpha * light).sum()
        return spent * (t[sel] ** 2 * alpha[sel] * light[sel] / weight[sel]).sum()

    one = np.ones_like(g)
    ratios = "  ".join(f"{k} {error(g, s) / error(one, s):.3f}" for k, s in parts.items())
    print(f"{argv[1]}: error with the importance / without: {ratios}")


if __name__ == "__main__":
    main(sys.argv)
