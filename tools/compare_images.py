#!/usr/bin/env python3
"""Compare an image A with a reference B by their means and block means (DESIGN §6).

    tools/.venv/bin/python tools/compare_images.py ours.exr mitsuba.exr [--block 32]
        [--mean-tol 0.01] [--block-tol 0.03] [--channels R,G,B | --prefix indirect] [--json]

Both files are read with OpenImageIO. Each channel is compared on its own (not luminance, so that
a colour error cannot hide behind a right brightness):
  mean:  |mean(A) - mean(B)| / |mean(B)| over the whole image;
  block: the image is cut into BLOCKxBLOCK tiles (edge tiles are smaller) and each tile's mean is
         compared the same way; the worst tile counts. A tile whose reference mean is below --floor
         (absolute radiance, default 1e-3) is divided by the floor instead, i.e. judged by its
         absolute difference: near-black tiles then neither fail on noise nor pass a gross error.
--exclude-above T leaves out of the tile means every pixel within one pixel of a pixel brighter
than T (any channel, either image): directly seen emitters, whose sub-pixel coverage noise takes
thousands of spp to average out of a tile (the Cornell box's light edge alone moves its 32x32 tile by
~3% at 64 spp). Both images use the same pixels; the image means keep every pixel.
The verdict is the worst channel. A non-finite pixel (NaN, inf) in either image is a failure.
Exit codes (as idiff): 0 within both tolerances, 1 differs, 2 usage or input error.
"""
import argparse
import json
import math
import sys

PROG = "compare_images.py"


def fail(what, message):
    print(f"{PROG}: {what}: {message}", file=sys.stderr)
    sys.exit(2)


def read_channels(path, names):
    """{name: H x W float64 array} for the named channels of an image file."""
    import numpy as np
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(path)
    if buf.has_error or not buf.init_spec(path, 0, 0):
        fail(path, f"cannot read: {buf.geterror().strip() or oiio.geterror().strip()}")
    have = list(buf.spec().channelnames)
    missing = [n for n in names if n not in have]
    if missing:
        fail(path, f"no channel {', '.join(missing)} (has: {', '.join(have)})")
    pixels = buf.get_pixels(oiio.FLOAT)
    if buf.has_error or pixels is None:
        fail(path, f"cannot read pixels: {buf.geterror().strip()}")
    pixels = np.asarray(pixels, dtype=np.float64).reshape(buf.spec().height, buf.spec().width, len(have))
    return {n: pixels[:, :, have.index(n)] for n in names}


def excluded_pixels(ca, cb, above):
    """Pixels within one pixel (3x3) of a pixel brighter than `above` in any channel of either image."""
    import numpy as np

    bright = np.zeros(next(iter(ca.values())).shape, dtype=bool)
    for c in list(ca.values()) + list(cb.values()):
        bright |= c > above
    padded = np.pad(bright, 1)
    h, w = bright.shape
    return np.logical_or.reduce([padded[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)])


def block_means(img, keep, block):
    """Means over the kept pixels of the block x block tiles of a 2-D array (edge tiles may be
    smaller; NaN for a tile with no kept pixel)."""
    import numpy as np

    h, w = img.shape
    sums = np.add.reduceat(np.add.reduceat(np.where(keep, img, 0.0), range(0, h, block), 0), range(0, w, block), 1)
    counts = np.add.reduceat(np.add.reduceat(keep.astype(float), range(0, h, block), 0), range(0, w, block), 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums / counts


def compare_channel(a, b, keep, block, floor):
    import numpy as np

    finite = bool(np.isfinite(a).all() and np.isfinite(b).all())
    ma, mb = float(a.mean()), float(b.mean())
    mean_rel = abs(ma - mb) / max(abs(mb), floor)
    ba, bb = block_means(a, keep, block), block_means(b, keep, block)
    rel = np.abs(ba - bb) / np.maximum(np.abs(bb), floor)
    judged = ~np.isnan(bb)
    worst = np.unravel_index(np.nanargmax(np.where(judged, rel, -1.0)), rel.shape) if finite else (0, 0)
    return {
        "mean_a": ma, "mean_b": mb, "mean_rel": mean_rel,
        "block_rel_max": float(rel[worst]), "worst_block_xy": [int(worst[1]) * block, int(worst[0]) * block],
        "blocks": int(judged.sum()), "blocks_below_floor": int((np.abs(bb[judged]) < floor).sum()),
        "finite": finite,
    }


def strict(x):
    """x with every NaN or infinity replaced by None, for strict JSON."""
    if isinstance(x, dict):
        return {k: strict(v) for k, v in x.items()}
    if isinstance(x, list):
        return [strict(v) for v in x]
    return None if isinstance(x, float) and not math.isfinite(x) else x


def main():
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    ap.add_argument("a", help="image to check (EXR or anything OpenImageIO reads)")
    ap.add_argument("b", help="reference image")
    ap.add_argument("--block", type=int, default=32, help="tile size in pixels [32]")
    ap.add_argument("--mean-tol", type=float, default=0.01, help="largest relative difference of image means [0.01]")
    ap.add_argument("--block-tol", type=float, default=0.03, help="largest relative difference of tile means [0.03]")
    ap.add_argument("--exclude-above", type=float, metavar="T",
                    help="leave pixels near a pixel brighter than T (directly seen emitters) out of the tile means [off]")
    ap.add_argument("--floor", type=float, default=1e-3, help="smallest denominator, absolute radiance [1e-3]")
    group = ap.add_mutually_exclusive_group()
    group.add_argument("--channels", default="R,G,B", help="comma-separated channel names, in both files [R,G,B]")
    group.add_argument("--prefix", help="compare PREFIX.R, PREFIX.G, PREFIX.B (e.g. indirect), in both files")
    ap.add_argument("--json", action="store_true", help="also print the results as one JSON object (last line)")
    a = ap.parse_args()
    if a.block < 1 or a.mean_tol < 0 or a.block_tol < 0 or a.floor <= 0:
        fail("arguments", "--block and --floor must be positive, tolerances non-negative")
    names = [f"{a.prefix}.{c}" for c in "RGB"] if a.prefix else [n.strip() for n in a.channels.split(",") if n.strip()]
    if not names:
        fail("--channels", "no channel named")

    ca, cb = read_channels(a.a, names), read_channels(a.b, names)
    shape_a, shape_b = ca[names[0]].shape, cb[names[0]].shape
    if shape_a != shape_b:
        fail(a.a, f"is {shape_a[1]}x{shape_a[0]}, the reference {a.b} is {shape_b[1]}x{shape_b[0]}")

    import numpy as np

    keep = np.ones(shape_b, dtype=bool)
    if a.exclude_above is not None:
        keep = ~excluded_pixels(ca, cb, a.exclude_above)
    results = {n: compare_channel(ca[n], cb[n], keep, a.block, a.floor) for n in names}
    mean_worst = max(r["mean_rel"] for r in results.values())
    block_worst = max(r["block_rel_max"] for r in results.values())
    finite = all(r["finite"] for r in results.values())
    ok = finite and mean_worst <= a.mean_tol and block_worst <= a.block_tol

    print(f"{'channel':<12} {'mean A':>10} {'mean B':>10} {'mean rel':>9} {'worst block':>11}  at (x,y)  below floor")
    for n, r in results.items():
        print(f"{n:<12} {r['mean_a']:10.5f} {r['mean_b']:10.5f} {r['mean_rel']:9.4%} {r['block_rel_max']:11.4%}"
              f"  {tuple(r['worst_block_xy'])!s:<9} {r['blocks_below_floor']}/{r['blocks']}"
              + ("" if r["finite"] else "  NON-FINITE PIXELS"))
    print(f"{'OK' if ok else 'DIFFERS'}: mean {mean_worst:.4%} (tol {a.mean_tol:.2%}), "
          f"worst {a.block}x{a.block} block {block_worst:.4%} (tol {a.block_tol:.2%})"
          + ("" if finite else ", non-finite pixels")
          + ("" if keep.all() else f"; {int((~keep).sum())} pixels near ones > {a.exclude_above:g} left out of the blocks"))
    if a.json:
        print(json.dumps(strict({"ok": ok, "mean_rel_max": mean_worst, "block_rel_max": block_worst, "finite": finite,
                          "block": a.block, "mean_tol": a.mean_tol, "block_tol": a.block_tol, "floor": a.floor,
                          "excluded_pixels": int((~keep).sum()), "channels": results})))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
