#!/usr/bin/env python3
"""Benchmark: path samples per second of our path tracer against Mitsuba 3 (DESIGN §6).

    cargo build --release && tools/.venv/bin/python tools/bench_pt.py [--spp 64] [--runs 3] [--update BENCHMARKS.md]

Renders fixtures/scenes/cornell-box.json (256x256, max_depth 8 = Mitsuba's 9) with
  - ours: target/release/mixmc-omc --spp N, timed by the EXR's mixmc.seconds (the render loop only:
    not scene loading, BVH building, the G-buffer or writing the EXR; wall time is shown beside it);
  - Mitsuba 3 llvm_ad_rgb and scalar_rgb on the exported scene, through tools/mitsuba_render.py
    (render calls only, not import or scene loading), runs+1 renders in one process: the first,
    which compiles the JIT kernels, is reported apart as "cold" and left out of the median;
  - on a host with AVX-512, llvm_ad_rgb again with its kernels compiled for 8 lanes (AVX2), the
    code it runs on an AVX2 host: the two peers at one vector width on one machine.
Every renderer uses all cores. Prints a Markdown section; --update FILE replaces (or appends) the
section "Path tracing vs Mitsuba 3" in FILE. A benchmark, not a test: nothing is asserted.
"""
import argparse
import datetime
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from mitsuba_render import host_flags  # noqa: E402
SCENE = os.path.join(ROOT, "fixtures/scenes/cornell-box.json")
TITLE = "## Path tracing vs Mitsuba 3"


def run(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"bench_pt.py: {' '.join(cmd)} failed:\n{out.stderr.strip()}")
    return out.stdout


def exr_float(path, name):
    import OpenImageIO as oiio

    return float(oiio.ImageInput.open(path).spec().getattribute(name))


def bench_ours(tmp, spp, runs, depth):
    omc = os.path.join(ROOT, "target/release/mixmc-omc")
    if not os.access(omc, os.X_OK):
        sys.exit("bench_pt.py: target/release/mixmc-omc is missing: run cargo build --release")
    render, wall, cpu = [], [], []
    for r in range(runs):
        out = os.path.join(tmp, f"ours{r}.exr")
        t, c = time.perf_counter(), children_cpu()
        run([omc, SCENE, "-o", out, "--spp", str(spp), "--seed", str(r + 1), "--max-depth", str(depth), "-q"])
        wall.append(time.perf_counter() - t)
        cpu.append(children_cpu() - c)
        render.append(exr_float(out, "mixmc.seconds"))
    return render, wall, cpu


def children_cpu():
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def bench_mitsuba(xml, variant, spp, runs, depth, lanes=None):
    out = run([sys.executable, os.path.join(ROOT, "tools/mitsuba_render.py"), xml, "--variant", variant,
               "--spp", str(spp), "--max-depth", str(depth), "--runs", str(runs + 1),
               "--pass-samples", str(256 * 256 * spp), "--json"]
              + ([] if lanes is None else ["--llvm-lanes", str(lanes)]))
    res = json.loads(out.strip().splitlines()[-1])
    return res["seconds"][0], res["seconds"][1:], res["cpu_seconds"][1:], res["mitsuba"]


def machine():
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            model = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{os.cpu_count()} logical CPUs ({model}), {platform.system()} {platform.release()}"


def main():
    ap = argparse.ArgumentParser(prog="bench_pt.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of every render [64]")
    ap.add_argument("--runs", type=int, default=3, help="timed runs per renderer; the median counts [3]")
    ap.add_argument("--update", metavar="FILE", help="write the section into this Markdown file")
    a = ap.parse_args()
    if a.spp < 1 or a.runs < 1:
        sys.exit("bench_pt.py: --spp and --runs must be positive")
    depth = 8
    samples = 256 * 256 * a.spp
    load_before = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory(prefix="mixmc-bench-") as tmp:
        run([os.path.join(ROOT, "target/release/mixmc-scene"), "export", SCENE, "--mitsuba", tmp])
        xml = os.path.join(tmp, "scene.xml")
        render, wall, cpu = bench_ours(tmp, a.spp, a.runs, depth)
        rows.append(("mixmc-omc `--method pt`", None, render, cpu, f"process wall {statistics.median(wall):.2f} s"))
        for variant in ("llvm_ad_rgb", "scalar_rgb"):
            cold, warm, cpu, version = bench_mitsuba(xml, variant, a.spp, a.runs, depth)
            rows.append((f"Mitsuba {version} `{variant}`", cold, warm, cpu, ""))
        if "avx512f" in host_flags():
            cold, warm, cpu, version = bench_mitsuba(xml, "llvm_ad_rgb", a.spp, a.runs, depth, lanes=8)
            rows.append((f"Mitsuba {version} `llvm_ad_rgb`, 8 lanes", cold, warm, cpu,
                         "`--llvm-lanes 8`: its AVX2 code"))
    load_after = os.getloadavg()[0]

    ours = samples / statistics.median(rows[0][2])
    lines = [
        TITLE, "",
        f"`tools/.venv/bin/python tools/bench_pt.py --spp {a.spp} --runs {a.runs}` on "
        f"{datetime.date.today().isoformat()}; {machine()}; 1-minute load average {load_before:.2f} before, "
        f"{load_after:.2f} after (other jobs share the machine, so the numbers are a lower bound).", "",
        f"Cornell box (`fixtures/scenes/cornell-box.json`), 256x256, {a.spp} spp = {samples / 1e6:.2f} M path "
        f"samples per run, max_depth {depth} (Mitsuba `path` max_depth {depth + 1}), all cores. Ours is timed "
        "by `mixmc.seconds` (render loop only: no scene load, BVH, G-buffer or EXR write); Mitsuba by its "
        "`mi.render` calls (no import or scene load). Median of the warm runs; \"cold\" is Mitsuba's first "
        "render in the process, JIT compilation included (Dr.Jit also caches kernels on disk, in ~/.drjit), "
        "left out of the median. Samples per CPU-second (user + system time of all threads; for ours the "
        "whole process) are less disturbed by other jobs on the machine.", "",
        "| renderer | median s | M samples/s | speed of ours ÷ its | M samples per CPU-s | cold (1st) s | runs (s) | note |",
        "|---|---:|---:|---:|---:|---:|---|---|",
    ]
    for name, cold, times, cpu, note in rows:
        med = statistics.median(times)
        rate = samples / med
        lines.append(f"| {name} | {med:.2f} | {rate / 1e6:.3f} | {ours / rate:.2f} | "
                     f"{samples / statistics.median(cpu) / 1e6:.3f} | {'' if cold is None else f'{cold:.2f}'} | "
                     f"{', '.join(f'{t:.2f}' for t in times)} | {note} |")
    section = "\n".join(lines) + "\n"
    print(section)
    if a.update:
        update_section(a.update, TITLE, section)


def update_section(path, title, section):
    """Replace the Markdown section starting with `title` in `path` (up to the next `## `), or
    append it; shared with the other benchmark scripts that write BENCHMARKS.md."""
    text = open(path).read() if os.path.exists(path) else "# Benchmarks\n"
    start = text.find(title)
    if start >= 0:
        end = text.find("\n## ", start + len(title))
        text = text[:start] + section + ("" if end < 0 else text[end:])
    else:
        text = text.rstrip("\n") + "\n\n" + section
    with open(path, "w") as f:
        f.write(text)

if __name__ == "__main__":
    main()
