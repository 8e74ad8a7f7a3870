#!/usr/bin/env python3
"""Speed of mixmc-mask on a 3840x2160 input against OpenCV's medianBlur 5x5 + absdiff, in one run.

  tools/.venv/bin/python tools/bench_mask.py [--runs 5] [--workdir /tmp/mixmc-bench-mask] [--baseline DIR]
                                            [--threads N]

The input is the caustic scene rendered at 128x128 (16 spp), its G-buffer upscaled to 3840x2160 by
nearest neighbour and its indirect light upscaled bilinearly times per-pixel noise (lognormal,
sigma 0.5, plus 0.2% fireflies x50), so that the median has real work and the segments are the
scene's. mixmc-mask reports the seconds of its computation (after reading, before writing) in
--json, as wall time and as CPU time of all its threads (on a machine shared with other jobs the
wall time includes waiting for a core, the CPU time does not); OpenCV is timed alike on the float32
luminance, which it gets for free. Medians of --runs runs. --threads N runs both with N threads.
--baseline DIR also times DIR/mixmc-mask (another build, e.g. the main branch's target/release) with
the default settings, in the same run, so a change is measured against what it replaces under the
same load.
"""
import argparse
import json
import os
import platform
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


def make_input(path):
    small = path + ".small.exr"
    subprocess.run([os.path.join(BIN, "mixmc-omc"), os.path.join(ROOT, "fixtures/scenes/caustic.json"),
                    "-o", small, "--spp", "16", "-q"], check=True, stdout=subprocess.DEVNULL)
    inp = oiio.ImageInput.open(small)
    spec = inp.spec()
    px = inp.read_image(format="float")
    inp.close()
    names = list(spec.channelnames)
    rng = np.random.default_rng(1)
    noise = rng.lognormal(0.0, 0.5, (H, W)).astype(np.float32)
    noise[rng.random((H, W)) < 0.002] *= 50
    out = {}
    for i, n in enumerate(names):
        if n.startswith("indirect."):
            out[n] = cv2.resize(px[:, :, i], (W, H), interpolation=cv2.INTER_LINEAR) * noise
        elif n in ("Z", "matid") or n.startswith("N."):
            out[n] = cv2.resize(px[:, :, i], (W, H), interpolation=cv2.INTER_NEAREST)
    keep = sorted(out)
    spec = oiio.ImageSpec(W, H, len(keep), "float")
    spec.channelnames = keep
    # A 4K frame at this scene's field of view: the depth rule's pixel size follows the height.
    spec.attribute("mixmc.fov_y", 40.0)
    o = oiio.ImageOutput.create(path)
    o.open(path, spec)
    o.write_image(np.stack([out[k] for k in keep], axis=-1))
    o.close()
    y = (np.float32(0.2126) * out["indirect.R"] + np.float32(0.7152) * out["indirect.G"]
         + np.float32(0.0722) * out["indirect.B"])
    return np.ascontiguousarray(y)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--workdir", default="/tmp/mixmc-bench-mask")
    p.add_argument("--baseline", help="directory with another build's mixmc-mask to time beside this one")
    p.add_argument("--threads", type=int, help="threads for mixmc-mask and OpenCV [default: all cores]")
    args = p.parse_args()
    threads = ["--threads", str(args.threads)] if args.threads else []
    if args.threads:
        cv2.setNumThreads(args.threads)
    os.makedirs(args.workdir, exist_ok=True)
    src = os.path.join(args.workdir, "input-4k.exr")
    y = make_input(src)
    variants = [("mixmc-mask (7x7, default)", BIN, []), ("mixmc-mask --window 5", BIN, ["--window", "5"]),
                ("mixmc-mask --paper", BIN, ["--paper"])]
    if args.baseline:
        variants.insert(1, (f"baseline {args.baseline}/mixmc-mask (7x7, default)", args.baseline, []))
    # Rounds interleave every variant and OpenCV, so a change in the machine's load hits all alike,
    # in alternating order: on a busy host the first run after another process's exit can be the
    # slow one (fresh pages to zero), and a fixed order would charge that to one variant.
    comp = {label: [] for label, _, _ in variants}
    cpu = {label: [] for label, _, _ in variants}
    wall = {label: [] for label, _, _ in variants}
    cv, cv_cpu = [], []
    for round in range(args.runs):
        for label, bin_dir, extra in (variants if round % 2 == 0 else variants[::-1]):
            t = time.perf_counter()
            r = subprocess.run([os.path.join(bin_dir, "mixmc-mask"), src, "-o", os.path.join(args.workdir, "mask.exr"),
                                "--json"] + threads + extra, check=True, capture_output=True, text=True)
            wall[label].append(time.perf_counter() - t)
            summary = json.loads(r.stdout)
            comp[label].append(summary["compute_seconds"])
            # Builds from before the field existed report no CPU time.
            cpu[label].append(summary.get("compute_cpu_seconds", float("nan")))
        t, c = time.perf_counter(), time.process_time()
        d = cv2.absdiff(y, cv2.medianBlur(y, 5))
        cv.append(time.perf_counter() - t)
        cv_cpu.append(time.process_time() - c)
    assert d.shape == y.shape
    results = {label: (statistics.median(comp[label]), statistics.median(cpu[label]), statistics.median(wall[label]))
               for label in comp}
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"OpenCV {cv2.__version__} with {cv2.getNumThreads()} threads; {W}x{H}; median of {args.runs} runs")
    print("| what | compute s | compute CPU s | whole process s (read EXR, mask, write EXR) |")
    print("|---|---|---|---|")
    for label, (c, u, w) in results.items():
        print(f"| {label} | {c:.3f} | {u:.3f} | {w:.3f} |")
    print(f"| OpenCV medianBlur 5x5 + absdiff (float32) | {statistics.median(cv):.3f} | {statistics.median(cv_cpu):.3f} | - |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
