#!/usr/bin/env python3
"""Whole-process time and peak memory of mixmc-composite on a 3840x2160 frame, optionally beside
another build's, in one run.

  tools/.venv/bin/python tools/bench_composite.py [--runs 3] [--workdir /tmp/mixmc-bench-composite]
                                                [--baseline DIR]

The OMC input is the caustic scene rendered at 128x128 (16 spp) with every channel upscaled to
3840x2160 (nearest for the G-buffer, bilinear for light) and its indirect light times lognormal
noise; the MCMC input is that indirect light; the mask is mixmc-mask's of the OMC input (--switch 1,
so eq. (2) and FXAA run). What is timed is the whole process: reading three EXRs (17, 4 and 3
channels), eq. (2), FXAA on the mask's borders, writing R,G,B. Wall seconds and the peak resident
memory (ru_maxrss of the child) are medians of --runs runs; --baseline DIR times DIR/mixmc-composite
in the same rounds, alternating order, and checks that both write the same pixels.
"""
import argparse
import os
import statistics
import subprocess
import sys
import time

import cv2
import numpy as np
import OpenImageIO as oiio

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release")
W, H = 3840, 2160


def write(path, channels, attrs=()):
    keep = sorted(channels)
    spec = oiio.ImageSpec(W, H, len(keep), "float")
    spec.channelnames = keep
    for k, v in attrs:
        spec.attribute(k, v)
    o = oiio.ImageOutput.create(path)
    o.open(path, spec)
    o.write_image(np.stack([channels[k] for k in keep], axis=-1))
    o.close()


def make_inputs(workdir):
    small = os.path.join(workdir, "small.exr")
    subprocess.run([os.path.join(BIN, "mixmc-omc"), os.path.join(ROOT, "fixtures/scenes/caustic.json"),
                    "-o", small, "--spp", "16", "-q"], check=True, stdout=subprocess.DEVNULL)
    inp = oiio.ImageInput.open(small)
    names = list(inp.spec().channelnames)
    px = inp.read_image(format="float")
    inp.close()
    os.remove(small)
    noise = np.random.default_rng(2).lognormal(0.0, 0.5, (H, W)).astype(np.float32)
    out = {}
    for i, n in enumerate(names):
        nearest = n in ("Z", "matid") or n.startswith("N.")
        out[n] = cv2.resize(px[:, :, i], (W, H), interpolation=cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR)
        if n.startswith("indirect."):
            out[n] = out[n] * noise
    paths = {k: os.path.join(workdir, f"{k}.exr") for k in ("omc", "mcmc", "mask")}
    write(paths["omc"], out, [("mixmc.fov_y", 40.0)])
    write(paths["mcmc"], {c: out[f"indirect.{c}"] for c in "RGB"})
    subprocess.run([os.path.join(BIN, "mixmc-mask"), paths["omc"], "-o", paths["mask"], "--switch", "1"],
                   check=True, stdout=subprocess.DEVNULL)
    return paths


def run(bin_dir, paths, out):
    if os.path.exists(out):
        os.remove(out)
    t = time.perf_counter()
    p = subprocess.Popen([os.path.join(bin_dir, "mixmc-composite"), "--omc", paths["omc"], "--mask", paths["mask"],
                          "--mcmc", paths["mcmc"], "-o", out],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t
    if status != 0:
        sys.exit(f"{bin_dir}/mixmc-composite failed ({status})")
    return wall, usage.ru_maxrss / 1024.0


def pixels(path):
    inp = oiio.ImageInput.open(path)
    px = inp.read_image(format="float")
    inp.close()
    return px


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--workdir", default="/tmp/mixmc-bench-composite")
    p.add_argument("--baseline", help="directory with another build's mixmc-composite to time beside this one")
    args = p.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    paths = make_inputs(args.workdir)
    builds = [("this build", BIN)] + ([(f"baseline {args.baseline}", args.baseline)] if args.baseline else [])
    wall = {label: [] for label, _ in builds}
    rss = {label: [] for label, _ in builds}
    outs = {label: os.path.join(args.workdir, f"out-{i}.exr") for i, (label, _) in enumerate(builds)}
    for round in range(args.runs):
        for label, bin_dir in (builds if round % 2 == 0 else builds[::-1]):
            w, m = run(bin_dir, paths, outs[label])
            wall[label].append(w)
            rss[label].append(m)
    if args.baseline:
        same = np.array_equal(*(pixels(outs[label]) for label, _ in builds))
        print(f"same pixels: {same}")
    print(f"{W}x{H}; {os.cpu_count()} cores; median of {args.runs} runs")
    print("| build | whole process s | peak RSS MB | runs (s) |")
    print("|---|---:|---:|---|")
    for label, _ in builds:
        runs = ", ".join(f"{w:.2f}" for w in wall[label])
        print(f"| {label} | {statistics.median(wall[label]):.2f} | {statistics.median(rss[label]):.0f} | {runs} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
