#!/usr/bin/env python3
"""Independent checks of mixmc-mask's steps (DESIGN §6), written without looking at the Rust code's
data structures: OpenCV / NumPy for the median noise, SciPy's connected components for the segments.

  mask_reference.py noise OMC.exr MASK.exr --window W
      step 1: n = |Y - median_WxW(Y)| of the indirect luminance, borders clamped (edge padding).
      W = 5: OpenCV medianBlur (float32 supports 5x5 at most; it replicates the border).
      W = 3 or 7: NumPy sliding_window_view over np.pad(mode="edge").
      Exact equality everywhere, interior and border.
  mask_reference.py segments OMC.exr MASK.exr
      step 3: the same neighbour rule (equal matid, |dN| < normal_tol, and either |dz| < depth_tol
      pixel sizes or one end on a straight run of 1/z along the edge's axis: its two neighbours
      the same surface and |q- - 2q + q+| < depth_tol * pixel angle * q; background joins background
      only), components by scipy.sparse.csgraph; the partitions must be equal (ids compared after
      renumbering by first pixel).
  mask_reference.py alpha MASK.exr
      alpha takes only the values epsilon and 1, is constant inside each segment, never below epsilon.

Exit 0 when the check passes, 1 with a message when it fails, 2 on usage errors.
"""
import argparse
import math
import sys

import numpy as np
import OpenImageIO as oiio


def read(path):
    """All channels of an EXR as float32 arrays by name, plus its header attributes."""
    inp = oiio.ImageInput.open(path)
    if inp is None:
        sys.exit(f"mask_reference.py: {path}: {oiio.geterror()}")
    spec = inp.spec()
    pixels = inp.read_image(format="float")
    inp.close()
    chans = {name: np.ascontiguousarray(pixels[:, :, i]) for i, name in enumerate(spec.channelnames)}
    attrs = {a.name: a.value for a in spec.extra_attribs}
    return chans, attrs


def luminance(c):
    r, g, b = c["indirect.R"], c["indirect.G"], c["indirect.B"]
    # float32 throughout, in the same order as the definition: 0.2126 R + 0.7152 G + 0.0722 B.
    return np.float32(0.2126) * r + np.float32(0.7152) * g + np.float32(0.0722) * b


def median_filter(y, w):
    if w == 5:
        import cv2

        return cv2.medianBlur(y, 5)
    h = w // 2
    padded = np.pad(y, h, mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(padded, (w, w))
    return np.median(windows.reshape(y.shape[0], y.shape[1], w * w), axis=2).astype(np.float32)


def check_noise(omc, mask, w):
    c, _ = read(omc)
    m, _ = read(mask)
    y = luminance(c)
    want = np.abs(y - median_filter(y, w))
    got = m["noise"]
    bad = got != want
    if bad.any():
        ys, xs = np.nonzero(bad)
        print(f"noise differs at {bad.sum()} pixels, first ({xs[0]},{ys[0]}): {got[ys[0], xs[0]]} vs {want[ys[0], xs[0]]}")
        return 1
    print(f"noise {w}x{w}: {y.size} pixels identical")
    return 0


def canonical(labels):
    """Renumber ids by first occurrence in raster order."""
    flat = labels.ravel()
    _, first = np.unique(flat, return_index=True)
    order = np.argsort(first)
    new = np.empty(order.size, dtype=np.int64)
    new[order] = np.arange(order.size)
    lookup = dict(zip(np.unique(flat), new))
    return np.vectorize(lookup.get)(flat).reshape(labels.shape)


def check_segments(omc, mask):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    c, _ = read(omc)
    m, attrs = read(mask)
    ntol = np.float32(attrs["mixmc.mask.normal_tol"])
    dtol = np.float32(attrs["mixmc.mask.depth_tol"])
    fov = attrs["mixmc.mask.fov_y"]
    h, w = c["Z"].shape
    angle = np.float32(2.0 * math.tan(math.radians(fov) * 0.5) / h)
    z, mat = c["Z"], c["matid"]
    nrm = np.stack([c["N.X"], c["N.Y"], c["N.Z"]], axis=-1)
    bg = ~np.isfinite(z) | (mat < 0)
    idx = np.arange(h * w).reshape(h, w)

    def same_surface(sa, sb):
        dn = nrm[sa] - nrm[sb]
        dn2 = dn[..., 0] ** 2 + dn[..., 1] ** 2 + dn[..., 2] ** 2
        return ~bg[sa] & ~bg[sb] & (mat[sa] == mat[sb]) & (dn2 < ntol * ntol)

    def linear(axis):
        """Per pixel: its two neighbours along `axis` continue its surface on a line of 1/z."""
        flag = np.zeros((h, w), dtype=bool)
        inner = tuple(slice(1, -1) if a == axis else slice(None) for a in (0, 1))
        lo = tuple(slice(None, -2) if a == axis else slice(None) for a in (0, 1))
        hi = tuple(slice(2, None) if a == axis else slice(None) for a in (0, 1))
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            ql, q, qr = np.float32(1) / z[lo], np.float32(1) / z[inner], np.float32(1) / z[hi]
            straight = np.abs((qr - q) - (q - ql)) < dtol * angle * q
        flag[inner] = same_surface(lo, inner) & same_surface(inner, hi) & straight
        return flag

    def joins(sa, sb, flag):
        bga, bgb = bg[sa], bg[sb]
        za, zb = z[sa], z[sb]
        with np.errstate(invalid="ignore"):
            near = np.abs(za - zb) < dtol * np.float32(0.5) * (za + zb) * angle
        surf = same_surface(sa, sb) & (near | flag[sa] | flag[sb])
        return (bga & bgb) | surf

    edges = []
    for axis, sa, sb in [(1, (slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                         (0, (slice(1, None), slice(None)), (slice(None, -1), slice(None)))]:
        j = joins(sa, sb, linear(axis))
        edges.append((idx[sa][j], idx[sb][j]))
    a = np.concatenate([e[0] for e in edges])
    b = np.concatenate([e[1] for e in edges])
    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(h * w, h * w))
    count, labels = connected_components(graph, directed=False)
    want = canonical(labels.reshape(h, w))
    got = canonical(m["segment"].astype(np.int64))
    if count != int(attrs["mixmc.mask.segments"]) or (want != got).any():
        print(f"segments differ: {count} vs {int(attrs['mixmc.mask.segments'])} segments, "
              f"{(want != got).sum()} pixels labelled differently")
        return 1
    print(f"segments: {count} segments, identical partition")
    return 0


def check_alpha(mask):
    m, attrs = read(mask)
    eps = np.float32(attrs["mixmc.mask.epsilon"])
    alpha, seg = m["alpha"], m["segment"].astype(np.int64)
    values = set(np.unique(alpha).tolist())
    if not values <= {float(eps), 1.0}:
        print(f"alpha takes values {sorted(values)}, not only {{{eps}, 1}}")
        return 1
    if alpha.min() < eps:
        print(f"alpha below epsilon: {alpha.min()}")
        return 1
    per_seg_min = np.full(seg.max() + 1, np.inf)
    per_seg_max = np.full(seg.max() + 1, -np.inf)
    np.minimum.at(per_seg_min, seg.ravel(), alpha.ravel())
    np.maximum.at(per_seg_max, seg.ravel(), alpha.ravel())
    mixed = np.nonzero(per_seg_min != per_seg_max)[0]
    if mixed.size:
        print(f"alpha not constant in {mixed.size} segments (first: {mixed[0]})")
        return 1
    print(f"alpha: values {sorted(values)}, constant in each of {seg.max() + 1} segments")
    return 0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    n = sub.add_parser("noise")
    n.add_argument("omc")
    n.add_argument("mask")
    n.add_argument("--window", type=int, default=7, choices=[3, 5, 7])
    s = sub.add_parser("segments")
    s.add_argument("omc")
    s.add_argument("mask")
    a = sub.add_parser("alpha")
    a.add_argument("mask")
    args = p.parse_args()
    if args.cmd == "noise":
        return check_noise(args.omc, args.mask, args.window)
    if args.cmd == "segments":
        return check_segments(args.omc, args.mask)
    return check_alpha(args.mask)


if __name__ == "__main__":
    sys.exit(main())
