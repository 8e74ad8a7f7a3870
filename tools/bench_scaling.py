#!/usr/bin/env python3
"""Benchmark (issue 11): per-sample cost of PT, BPT and MMLT, thread scaling, and linearity in
pixels and samples, all on the Cornell box, all in one run of this script.

    cargo build --release && tools/.venv/bin/python tools/bench_scaling.py [--runs 3] [--update BENCHMARKS.md]

Every render's time is its own measurement of the render loop, read from its EXR header
(`mixmc.seconds` for the OMC methods; `mixmc.chain_seconds` for MMLT: its chains only, not the
bootstrap or the estimate of b), so scene loading, BVH building, the G-buffer and writing the
file are left out. CPU seconds (user + system of the whole process, from rusage) are shown
beside: on a shared machine they move less than wall time. Medians of --runs runs, seeds 1..runs.

- rates: PT and BPT samples per second and MMLT mutations per second at 1 and 2 threads; the
  scaling column is the 2-thread rate over the 1-thread rate (goal ≥ 1.9, which needs an
  otherwise idle machine to mean anything).
- per sample: BPT's cost per sample over PT's (goal ≤ 2.5); MMLT's mutations per second over
  BPT's samples per second (goal ≥ 0.8).
- linearity: PT seconds per (pixel · sample) at 256², 512², 1024² × 8 spp and at 256² × 8, 16,
  32 spp (the film size is changed in a copy of the scene), relative to the first.
A benchmark, not a test: nothing is asserted.
"""
import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_pt import children_cpu, exr_float, update_section  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "fixtures/scenes/cornell-box.json")
TITLE = "## Scaling: threads, pixels, samples, and BPT/MMLT against PT"
BIN = os.path.join(ROOT, "target/release")


def render(tmp, tool, scene, args, seed, key):
    """One render: (seconds from the header, CPU seconds of the process, (closest, shadow) ray
    queries from the header)."""
    out = os.path.join(tmp, "x.exr")
    cmd = [os.path.join(BIN, tool), scene, "-o", out, "--seed", str(seed), "-q", *args]
    c = children_cpu()
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"bench_scaling.py: {' '.join(cmd)} failed:\n{done.stderr.strip()}")
    cpu = children_cpu() - c
    secs = exr_float(out, key)
    rays = (exr_float(out, "mixmc.rays_closest"), exr_float(out, "mixmc.rays_shadow"))
    os.remove(out)
    return secs, cpu, rays


def median_of(runs, f):
    """Medians of seconds and CPU seconds over seeds 1..runs, and the mean ray counts."""
    got = [f(seed) for seed in range(1, runs + 1)]
    rays = tuple(statistics.mean(g[2][i] for g in got) for i in (0, 1))
    return statistics.median(g[0] for g in got), statistics.median(g[1] for g in got), rays


def scene_at(tmp, size):
    with open(SCENE) as f:
        desc = json.load(f)
    desc["film"]["width"] = desc["film"]["height"] = size
    path = os.path.join(tmp, f"cornell-{size}.json")
    with open(path, "w") as f:
        json.dump(desc, f)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--pt-spp", type=int, default=16)
    ap.add_argument("--bpt-spp", type=int, default=4)
    ap.add_argument("--mmlt-mpp", type=int, default=16, help="MMLT mutations per pixel")
    ap.add_argument("--update", help="replace this section in the given Markdown file")
    a = ap.parse_args()
    with open(SCENE) as f:
        film = json.load(f)["film"]
    pixels = film["width"] * film["height"]
    load_before = os.getloadavg()[0]
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        methods = [
            ("PT", "mixmc-omc", ["--method", "pt", "--spp", str(a.pt_spp)], a.pt_spp, "mixmc.seconds"),
            ("BPT", "mixmc-omc", ["--method", "bpt", "--spp", str(a.bpt_spp)], a.bpt_spp, "mixmc.seconds"),
            (
                "MMLT",
                "mixmc-mmlt",
                ["--mutations-per-pixel", str(a.mmlt_mpp)],
                a.mmlt_mpp,
                "mixmc.chain_seconds",
            ),
        ]
        rates = {}
        lines += [
            "| renderer | per pixel | threads | median s | M/s | M per CPU-s | 2 threads ÷ 1 "
            "| rays per sample: closest + shadow | M rays/s |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for name, tool, args, per_px, key in methods:
            for threads in (1, 2):
                secs, cpu, (closest, shadow) = median_of(
                    a.runs,
                    lambda s: render(tmp, tool, SCENE, [*args, "--threads", str(threads)], s, key),
                )
                samples = pixels * per_px
                rates[(name, threads)] = samples / secs / 1e6
                scale = f"{rates[(name, 2)] / rates[(name, 1)]:.2f}" if threads == 2 else ""
                lines.append(
                    f"| {name} | {per_px} | {threads} | {secs:.3f} | {rates[(name, threads)]:.3f} "
                    f"| {samples / cpu / 1e6:.3f} | {scale} "
                    f"| {closest / samples:.2f} + {shadow / samples:.2f} "
                    f"| {(closest + shadow) / secs / 1e6:.1f} |"
                )
        lines += [
            "",
            "| ratio (same run) | 1 thread | 2 threads | goal |",
            "|---|---:|---:|---|",
            "| BPT cost per sample ÷ PT's | "
            + " | ".join(f"{rates[('PT', t)] / rates[('BPT', t)]:.2f}" for t in (1, 2))
            + " | ≤ 2.5 |",
            "| MMLT mutations/s ÷ BPT samples/s | "
            + " | ".join(f"{rates[('MMLT', t)] / rates[('BPT', t)]:.2f}" for t in (1, 2))
            + " | ≥ 0.8 |",
            "",
            "| PT, 2 threads | pixels | spp | median s | ns per pixel-sample | relative |",
            "|---|---:|---:|---:|---:|---:|",
        ]
        base = None
        for size, spp in [(256, 8), (512, 8), (1024, 8), (256, 16), (256, 32)]:
            scene = scene_at(tmp, size)
            secs, _, _ = median_of(
                a.runs,
                lambda s: render(
                    tmp, "mixmc-omc", scene, ["--method", "pt", "--spp", str(spp), "--threads", "2"], s,
                    "mixmc.seconds",
                ),
            )
            ns = secs / (size * size * spp) * 1e9
            base = base or ns
            lines.append(f"| {size}² | {size * size} | {spp} | {secs:.3f} | {ns:.1f} | {ns / base:.2f} |")
    load_after = os.getloadavg()[0]
    cpu_name = next(
        (l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?"
    )
    intro = [
        TITLE,
        "",
        f"`tools/.venv/bin/python tools/bench_scaling.py --runs {a.runs}` on "
        f"{datetime.date.today()}; {os.cpu_count()} logical CPUs ({cpu_name}), {platform.system()} "
        f"{platform.release()}; 1-minute load average {load_before:.2f} before, {load_after:.2f} after. "
        f"Cornell box ({film['width']}×{film['height']}, max_depth 8); medians of {a.runs} runs; "
        "seconds from each render's header (render loop only; MMLT: chains only).",
        "",
    ]
    text = "\n".join(intro + lines) + "\n"
    print(text)
    if a.update:
        update_section(a.update, TITLE, text)


if __name__ == "__main__":
    main()
