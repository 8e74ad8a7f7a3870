#!/usr/bin/env python3
"""Each render's error in the indirect light inside a mask, against a reference, as the main job
linearises it (docs/main-job.md, eleventh round: what MMLT's pilot misses on cornell-torus).

    tools/.venv/bin/python tools/mask_error.py MASK.exr REFERENCE.exr IMAGE.exr [IMAGE.exr ...]

MASK is a `mixmc-mask` output (channel `alpha`; complex where alpha > 0.5), REFERENCE a
`mixmc-omc` render with `indirect.*` and `R,G,B`. An IMAGE with `indirect.*` channels (an OMC
render) is scored by them, one without (an MMLT `mcmc.exr`, which holds alpha*I in `R,G,B`) by
its `R,G,B`. The error is (slope * (x - ref))^2, mean over channels, summed over the complex
pixels and divided by all pixels (the image-mean share the job's rates use), where slope is the
derivative of the paper's LDR curve 255*clamp(x,0,1)^(1/2.2) at the reference's 3x3-smoothed
beauty (`linearise.py`, as in `src/mix/estimate.rs`). Also printed: the
relative difference of the image's and the reference's sums over the mask (a bias shows there).
"""
import sys

import numpy as np
import OpenImageIO as oiio

from linearise import box, channels, slope

INDIRECT = ["indirect.R", "indirect.G", "indirect.B"]
RGB = ["R", "G", "B"]


def main(argv):
    if len(argv) < 3:
        sys.exit(__doc__.split("\n\n")[1])
    mask, ref, images = argv[0], argv[1], argv[2:]
    inside = channels(mask, ["alpha"])[..., 0] > 0.5
    ref_i, ref_rgb = channels(ref, INDIRECT), channels(ref, RGB)
    k = slope(box(ref_rgb, 3))
    for path in images:
        names = INDIRECT if "indirect.R" in oiio.ImageBuf(path).spec().channelnames else RGB
        img = channels(path, names)
        if img.shape != ref_i.shape:
            sys.exit(f"mask_error.py: {path}: size differs from the reference's")
        err = ((k * (img - ref_i)) ** 2)[inside].sum() / 3 / inside.size
        bias = (img - ref_i)[inside].sum() / max(ref_i[inside].sum(), 1e-12)
        print(f"{path}: in-mask error {err:.3f}, sum {bias:+.4f} of the reference's")


if __name__ == "__main__":
    main(sys.argv[1:])
