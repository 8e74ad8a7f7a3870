#!/usr/bin/env python3
"""Benchmark: two builds of the renderers against each other, old and new alternated (ABBA).

    tools/.venv/bin/python tools/bench_abba.py OLD_DIR NEW_DIR [--rounds 3] [--scenes a,b,...]

OLD_DIR and NEW_DIR each hold a mixmc-omc and a mixmc-mmlt (copy them out of target/release
before and after a change). Each round runs A B B A (then B A A B), so a drift in the host's
speed falls on both. Per scene of the paper (default cornell-torus, cornell-water, room,
bathroom): BPT at 256², 4 spp, timed by the header's mixmc.seconds (the render loop); MMLT on
the 64² twin, 256 mutations per pixel, timed by mixmc.chain_seconds (the chains: no start-up)
and, from the same runs, mixmc.seconds.bootstrap (its start-up's bootstrap, 100 000 samples per
depth, which the main job pays inside its budget); and PT on the Cornell box (bench_pt's scene,
32 spp). Prints a Markdown table: each build's median seconds and the old ÷ new ratio of each
pair (median, min, max; above 1 = new faster). A benchmark, not a test: nothing is asserted.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def attr(path, name):
    import OpenImageIO as oiio

    return oiio.ImageBuf(path).spec().get_float_attribute(name)


def cases(scenes, out):
    scene = lambda name: os.path.join(ROOT, "fixtures/scenes", name + ".json")
    for sc in scenes:
        yield sc, [("bpt", "mixmc.seconds")], lambda d, sc=sc: [f"{d}/mixmc-omc", scene(sc), "-o", out, "--method", "bpt", "--spp", "4", "-q"]
        mmlt = [("mmlt", "mixmc.chain_seconds"), ("mmlt bootstrap", "mixmc.seconds.bootstrap")]
        yield sc, mmlt, lambda d, sc=sc: [f"{d}/mixmc-mmlt", scene(sc + "-tiny"), "-o", out, "--mutations-per-pixel", "256", "-q"]
    yield "cornell-box", [("pt", "mixmc.seconds")], lambda d: [f"{d}/mixmc-omc", scene("cornell-box"), "-o", out, "--spp", "32", "--max-depth", "8", "-q"]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("old")
    p.add_argument("new")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--scenes", default="cornell-torus,cornell-water,room,bathroom")
    a = p.parse_args()
    for d in (a.old, a.new):
        for exe in ("mixmc-omc", "mixmc-mmlt"):
            if not os.access(os.path.join(d, exe), os.X_OK):
                sys.exit(f"bench_abba.py: {d}/{exe} is missing")
    print("| scene | method | old median s | new median s | old ÷ new median | min | max |")
    print("|---|---|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "abba.exr")
        for sc, keys, cmd in cases(a.scenes.split(","), out):
            dirs, times = (a.old, a.new), {key: ([], []) for _, key in keys}
            for r in range(a.rounds):
                for i in (0, 1, 1, 0) if r % 2 == 0 else (1, 0, 0, 1):
                    run = subprocess.run(cmd(dirs[i]), capture_output=True, text=True)
                    if run.returncode != 0:
                        sys.exit(f"bench_abba.py: {' '.join(cmd(dirs[i]))} failed:\n{run.stderr.strip()}")
                    for _, key in keys:
                        times[key][i].append(attr(out, key))
            for method, key in keys:
                old, new = times[key]
                ratios = [o / n for o, n in zip(old, new)]
                print(
                    f"| {sc} | {method} | {statistics.median(old):.3f} | {statistics.median(new):.3f} "
                    f"| {statistics.median(ratios):.3f} | {min(ratios):.3f} | {max(ratios):.3f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
