#!/usr/bin/env python3
"""Independent reference computations for mixmc-diff and mixmc-merge (DESIGN §6).

Reads EXRs with OpenImageIO, computes with NumPy and NVIDIA's flip_evaluator; shares no code
with the Rust tools. Prints one JSON object.

  metrics_reference.py metrics IMAGE REFERENCE [--crop x,y,w,h]
      mse    = mean((ldr(a) - ldr(b))^2), ldr(x) = 255 * clip(x, 0, 1)^(1/2.2)
      relmse = mean((a - b)^2 / (b^2 + 0.01))
      flip   = mean LDR-FLIP of the sRGB 8-bit encodings (round(255 * srgb(clip(x, 0, 1))))
  metrics_reference.py merge OUT INPUT...
      the spp-weighted mean of the inputs' colour channels, compared with OUT's, and whether
      OUT's G-buffer channels equal the first input's
"""
import argparse
import json
import sys

import numpy as np
import OpenImageIO as oiio
import flip_evaluator

GBUFFER = ("Z", "matid")
GBUFFER_PREFIXES = ("N.", "albedo.")


def read(path):
    inp = oiio.ImageInput.open(path)
    if inp is None:
        sys.exit(f"metrics_reference.py: {path}: {oiio.geterror()}")
    spec = inp.spec()
    pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
    inp.close()
    channels = {name: pixels[:, :, i].astype(np.float32) for i, name in enumerate(spec.channelnames)}
    attrs = {a.name: a.value for a in spec.extra_attribs}
    return channels, attrs


def rgb(channels):
    return np.stack([channels["R"], channels["G"], channels["B"]], axis=-1)


def srgb8(x):
    x = np.nan_to_num(x.astype(np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    x = np.clip(x, 0.0, 1.0)
    s = np.where(x <= np.float32(0.0031308), np.float32(12.92) * x,
                 np.float32(1.055) * np.power(x, np.float32(1 / 2.4)) - np.float32(0.055))
    return np.floor(s * np.float32(255.0) + np.float32(0.5)).astype(np.uint8)


def metrics(args):
    a = rgb(read(args.image)[0]).astype(np.float64)
    b = rgb(read(args.reference)[0]).astype(np.float64)
    if args.crop:
        x, y, w, h = (int(v) for v in args.crop.split(","))
        a, b = a[y:y + h, x:x + w], b[y:y + h, x:x + w]
    ldr = lambda v: 255.0 * np.power(np.clip(np.nan_to_num(v, nan=0.0), 0.0, 1.0), 1 / 2.2)
    mse = float(np.mean((ldr(a) - ldr(b)) ** 2))
    relmse = float(np.mean((a - b) ** 2 / (b * b + 0.01)))
    ref8 = srgb8(b).astype(np.float32) / np.float32(255.0)
    test8 = srgb8(a).astype(np.float32) / np.float32(255.0)
    error_map, _, _ = flip_evaluator.evaluate(ref8, test8, "LDR", applyMagma=False)
    flip = float(np.mean(error_map.astype(np.float64)))
    print(json.dumps({"mse": mse, "relmse": relmse, "flip": flip}))


def is_gbuffer(name):
    return name in GBUFFER or name.startswith(GBUFFER_PREFIXES)


def merge(args):
    out, out_attrs = read(args.out)
    inputs = [read(p) for p in args.inputs]
    weights = [float(attrs["mixmc.spp"]) for _, attrs in inputs]
    total = sum(weights)
    max_abs = 0.0
    max_rel = 0.0
    gbuffer_equal = True
    for name, merged in out.items():
        if is_gbuffer(name):
            first = inputs[0][0][name]
            gbuffer_equal &= bool(np.array_equal(merged.view(np.uint32), first.view(np.uint32)))
            continue
        expect = sum(w * ch[name].astype(np.float64) for w, (ch, _) in zip(weights, inputs)) / total
        diff = np.abs(merged.astype(np.float64) - expect)
        max_abs = max(max_abs, float(diff.max()))
        max_rel = max(max_rel, float((diff / np.maximum(np.abs(expect), 1e-30)).max()))
    print(json.dumps({"max_abs_diff": max_abs, "max_rel_diff": max_rel, "gbuffer_equal": gbuffer_equal,
                      "spp": float(out_attrs["mixmc.spp"]), "expected_spp": total,
                      "channels": sorted(out.keys())}))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    m = sub.add_parser("metrics")
    m.add_argument("image")
    m.add_argument("reference")
    m.add_argument("--crop")
    g = sub.add_parser("merge")
    g.add_argument("out")
    g.add_argument("inputs", nargs="+")
    args = parser.parse_args()
    {"metrics": metrics, "merge": merge}[args.command](args)


if __name__ == "__main__":
    main()
