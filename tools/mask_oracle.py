#!/usr/bin/env python3
"""Precision and recall of mixmc-mask (default and --paper) against two oracle masks.

  tools/mask_oracle.py [--seeds 8] [--spp 64] [--tau 2.0] [--threads 1] [--workdir DIR]
                       [--reference 'DIR/{scene}-s1001.exr' --equal-time 40 --ratio 2 --visible 0.1]
                       SCENE.json...

The oracle: render each scene with mixmc-omc at --spp with --seeds independent seeds. Per pixel, take
the indirect luminance's mean mu and variance var over the seeds (the variance of one --spp render),
both averaged over a 9x9 box (a per-pixel variance from 8 seeds is itself too noisy for the rare
fireflies that matter). The relative error is r = sqrt(var) / max(mu, 0.05 * mean(mu)) (the floor keeps
nearly black pixels, whose error is invisible, out). A pixel is complex in the oracle when r > tau
(default 2: one render's error is twice the value itself; path tracing on the diffuse-only scenes at
64 spp stays below 1 at the 99.9th percentile, the caustic scene's floor and sphere reach 6-9). The masks are made from the seed-1 render.

The error oracle (with --reference, for each scene whose reference file exists): mixmc-omc (PT) and
mixmc-mmlt (indirect light) each render the scene for --equal-time seconds (seed 101, --threads
threads, MMLT with 20 000 bootstrap samples per depth, counted in its time), both at once. Per pixel, the squared
error of the indirect luminance against the reference's, averaged over a 9x9 box: e_omc and e_mmlt.
A pixel is complex when OMC's local RMS error is more than --ratio times MMLT's and is visible:
sqrt(e_omc) > --visible * max(ref, 0.05 * mean(ref)), ref the reference's box-averaged luminance.
The reference's own noise adds to both errors alike, so it can only lower the ratio (the oracle
errs towards marking fewer pixels).
Prints Markdown tables; exit 0.
"""
import argparse
import json
import os
import subprocess
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mask_reference import luminance, read  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release")


def oracle(paths, tau):
    ys = np.stack([luminance(read(p)[0]).astype(np.float64) for p in paths])
    mu = cv2.blur(ys.mean(axis=0), (9, 9), borderType=cv2.BORDER_REPLICATE)
    var = np.maximum(cv2.blur(ys.var(axis=0, ddof=1), (9, 9), borderType=cv2.BORDER_REPLICATE), 0.0)
    r = np.sqrt(var) / np.maximum(mu, 0.05 * mu.mean())
    return r > tau


def box(a):
    return cv2.blur(a, (9, 9), borderType=cv2.BORDER_REPLICATE)


def error_oracle(ref, omc, mmlt, ratio, visible):
    y_ref = luminance(read(ref)[0]).astype(np.float64)
    y_omc = luminance(read(omc)[0]).astype(np.float64)
    c = read(mmlt)[0]
    y_mmlt = (0.2126 * c["R"] + 0.7152 * c["G"] + 0.0722 * c["B"]).astype(np.float64)
    # The box filter's running sums can leave tiny negative values where the error is 0.
    e_omc, e_mmlt = (np.maximum(box((y - y_ref) ** 2), 0.0) for y in (y_omc, y_mmlt))
    level = np.maximum(box(y_ref), 0.05 * y_ref.mean())
    return (e_omc > ratio**2 * e_mmlt) & (np.sqrt(e_omc) > visible * level)


def render_equal_time(scene, name, args):
    """Both renders run at the same time, so that they share whatever else loads the machine alike."""
    out, running = {}, []
    for tool, extra in [("omc", []), ("mmlt", ["--bootstrap", "20000"])]:
        path = os.path.join(args.workdir, f"{name}-eqt-{tool}.exr")
        if not os.path.exists(path):
            running.append(subprocess.Popen(
                [os.path.join(BIN, f"mixmc-{tool}"), scene, "-o", path, "--time", str(args.equal_time),
                 "--seed", "101", "--threads", str(args.threads), "-q"] + extra, stdout=subprocess.DEVNULL))
        out[tool] = path
    for p in running:
        if p.wait() != 0:
            sys.exit(f"mask_oracle.py: {scene}: {p.args[0]} failed")
    return out


def tint(image, marked):
    """The image darkened, with the marked pixels in red."""
    t = (image * 0.4).astype(np.uint8)
    t[marked] = (0.5 * t[marked] + [0, 0, 160]).astype(np.uint8)
    return t


def scores(marked, truth):
    tp = (marked & truth).sum()
    prec = tp / marked.sum() if marked.sum() else float("nan")
    rec = tp / truth.sum() if truth.sum() else float("nan")
    return " | ".join("n/a" if np.isnan(v) else f"{v:.2f}" for v in (prec, rec))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scenes", nargs="+")
    p.add_argument("--seeds", type=int, default=8)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--tau", type=float, default=2.0)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--workdir", default="/tmp/mixmc-mask-oracle")
    p.add_argument("--reference", help="reference EXR per scene, '{scene}' replaced by the scene's name")
    p.add_argument("--equal-time", type=float, default=40.0)
    p.add_argument("--ratio", type=float, default=2.0)
    p.add_argument("--visible", type=float, default=0.1)
    p.add_argument("--sheet", help="write a PNG: per scene the render, both oracles, both masks (in red)")
    args = p.parse_args()
    sheet = []
    os.makedirs(args.workdir, exist_ok=True)
    print(f"variance oracle: {args.seeds} seeds x {args.spp} spp, tau = {args.tau}; error oracle: "
          f"{args.equal_time} s each, ratio {args.ratio}, visible {args.visible}\n")
    print("| scene | mask | complex | variance oracle | precision | recall | error oracle | precision | recall |")
    print("|---|---|---|---|---|---|---|---|---|")
    for scene in args.scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        renders = []
        for seed in range(1, args.seeds + 1):
            out = os.path.join(args.workdir, f"{name}-s{seed}.exr")
            if not os.path.exists(out):
                subprocess.run([os.path.join(BIN, "mixmc-omc"), scene, "-o", out, "--spp", str(args.spp),
                                "--seed", str(seed), "--threads", str(args.threads), "-q"],
                               check=True, stdout=subprocess.DEVNULL)
            renders.append(out)
        truth = oracle(renders, args.tau)
        ref = args.reference.replace("{scene}", name) if args.reference else None
        err_truth = None
        if ref and os.path.exists(ref):
            eqt = render_equal_time(scene, name, args)
            err_truth = error_oracle(ref, eqt["omc"], eqt["mmlt"], args.ratio, args.visible)
        image = read(renders[0])[0]
        rgb = np.stack([image["B"], image["G"], image["R"]], axis=-1)
        image = (np.clip(rgb / (1 + rgb), 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
        tiles = [image] + [tint(image, m) for m in (truth, err_truth if err_truth is not None else truth & False)]
        for mode in ["default", "paper"]:
            mask = os.path.join(args.workdir, f"{name}-mask-{mode}.exr")
            cmd = [os.path.join(BIN, "mixmc-mask"), renders[0], "-o", mask, "--json", "--threads", str(args.threads)]
            # The switch would hide what the mask marks; it is reported, then disabled here.
            cmd += ["--switch", "1"] + (["--paper"] if mode == "paper" else [])
            summary = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
            marked = read(mask)[0]["alpha"] == 1.0
            tiles.append(tint(image, marked))
            switch = " (switch)" if summary["complex_fraction"] > 0.35 else ""
            row = f"| {name} | {mode} | {marked.mean():.1%}{switch} | {truth.mean():.1%} | {scores(marked, truth)} |"
            if err_truth is None:
                row += " no reference | | |"
            else:
                row += f" {err_truth.mean():.1%} | {scores(marked, err_truth)} |"
            print(row)
        sheet.append(np.hstack(tiles))
    if args.sheet:
        width = max(r.shape[1] for r in sheet)  # scenes of other sizes: pad the rows with black
        full = np.vstack([np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0))) for r in sheet])
        # Half size: enough to see what is marked, and noisy renders compress badly.
        half = cv2.resize(full, (full.shape[1] // 2, full.shape[0] // 2), interpolation=cv2.INTER_AREA)
        cv2.imwrite(args.sheet, half, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return 0


if __name__ == "__main__":
    sys.exit(main())
