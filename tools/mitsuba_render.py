#!/usr/bin/env python3
"""Render a scene exported by `mixmc-scene export --mitsuba DIR` with Mitsuba 3 (DESIGN §6).

    tools/.venv/bin/python tools/mitsuba_render.py DIR/scene.xml -o mitsuba.exr --spp 256 --seed 7

Writes a float32 RGB EXR (channels R,G,B) with OpenImageIO and prints the render time and path
samples per second (width * height * spp / seconds). The time covers rendering only: not Python's
start-up, importing Mitsuba, loading the scene or writing the EXR. With a JIT variant (llvm_*) the
first render also compiles its kernels; `--runs N` renders N times with seeds seed, seed+1, ... and
reports every run, so that a benchmark can tell the first (cold) run from the warm ones.

`--max-depth D` uses mixmc's convention (DESIGN §3: D scattering vertices) and sets Mitsuba's
`max_depth` to D + 1; without it the scene file's integrator is used as written.

Large renders are split into passes of at most --pass-samples path samples (Mitsuba's JIT variants
hold a whole pass in memory); pass k of a run uses Mitsuba seed (seed * 4096 + k), and the passes
are averaged. Exit codes: 0 success, 2 bad input.

`--llvm-lanes N` (8 or 16; llvm_* variants only) compiles Dr.Jit's kernels for N lanes and the
matching generic x86-64 level (v3: AVX2, v4: AVX-512) instead of the host's widest:
on an AVX-512 host, `--llvm-lanes 8` is the code Mitsuba runs on an AVX2 host, so the two
peers can be compared at one vector width on one machine (BENCHMARKS.md, issue 26).
"""
import argparse
import json
import os
import sys
import time

PROG = "mitsuba_render.py"


def fail(what, message):
    print(f"{PROG}: {what}: {message}", file=sys.stderr)
    sys.exit(2)


def pick_variant(mi, wanted):
    """The requested variant, or llvm_ad_rgb if it works here, else scalar_rgb."""
    if wanted:
        if wanted not in mi.variants():
            fail(wanted, f"not a Mitsuba variant in this build (have: {', '.join(mi.variants())})")
        try:
            mi.set_variant(wanted)
        except Exception as e:  # e.g. the llvm variants without libLLVM
            fail(wanted, f"cannot be used here: {e}")
        return wanted
    try:
        mi.set_variant("llvm_ad_rgb")
        return "llvm_ad_rgb"
    except Exception:
        mi.set_variant("scalar_rgb")
        return "scalar_rgb"


# Dr.Jit's LLVM target per lane count: a generic CPU level and its features. Not 4 lanes on
# x86-64-v2: Dr.Jit's kernels call FMA, which SSE4.2 lacks (it aborts compiling them).
AVX2_FEATURES = "+sse4.2,+popcnt,+avx,+avx2,+fma,+f16c,+bmi,+bmi2,+lzcnt"
LLVM_TARGETS = {
    8: ("x86-64-v3", AVX2_FEATURES),
    16: ("x86-64-v4", AVX2_FEATURES + ",+avx512f,+avx512vl,+avx512dq,+avx512bw,+avx512cd"),
}


def host_flags():
    try:
        with open("/proc/cpuinfo") as f:
            return next((line.split(":", 1)[1].split() for line in f if line.startswith("flags")), [])
    except OSError:
        return []


def check_llvm_lanes(lanes):
    """Refuse a lane count Dr.Jit cannot be built for here, before Mitsuba is imported."""
    if lanes not in LLVM_TARGETS:
        fail("--llvm-lanes", f"{lanes}: must be one of {', '.join(map(str, LLVM_TARGETS))}")
    if lanes == 16 and "avx512f" not in host_flags():
        fail("--llvm-lanes", "16 lanes need AVX-512, which this CPU does not have")


def set_llvm_lanes(lanes, variant):
    """Compile Dr.Jit's LLVM kernels for `lanes` lanes from here on, through
    `jit_llvm_set_target`, which Dr.Jit's Python API does not expose. Called after the variant
    is set, before any kernel is compiled (measured: 2.5–2.6 M samples/s on the Cornell box at 8
    lanes against 4.3–4.4 at the Zen 5 host's 16, with no kernel run before it)."""
    import ctypes
    import drjit as dr

    if not variant.startswith("llvm_"):
        fail("--llvm-lanes", f"only for llvm_* variants, not {variant}")
    core = os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so")
    try:
        set_target = ctypes.CDLL(core)._Z19jit_llvm_set_targetPKcS0_j
    except (OSError, AttributeError) as e:
        fail("--llvm-lanes", f"this Dr.Jit has no jit_llvm_set_target: {e}")
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint]
    cpu, features = LLVM_TARGETS[lanes]
    set_target(cpu.encode(), features.encode(), lanes)


def render(mi, scene, integrator, width, height, spp, seed, pass_samples):
    """Average of passes of `spp` samples per pixel in total; returns (H x W x 3 array, seconds,
    CPU seconds of all the process's threads)."""
    import numpy as np

    per_pass = max(1, min(spp, pass_samples // (width * height)))
    total = np.zeros((height, width, 3), dtype=np.float64)
    start, cpu = time.perf_counter(), time.process_time()
    done, k = 0, 0
    while done < spp:
        n = min(per_pass, spp - done)
        img = mi.render(scene, integrator=integrator, spp=n, seed=(seed * 4096 + k) % 2**32)
        total += np.asarray(img, dtype=np.float64)[:, :, :3] * n  # forces evaluation of JIT variants
        done += n
        k += 1
    return (total / spp).astype(np.float32), time.perf_counter() - start, time.process_time() - cpu


def write_exr(path, rgb, attrs):
    import OpenImageIO as oiio

    h, w, _ = rgb.shape
    spec = oiio.ImageSpec(w, h, 3, "float")
    spec.channelnames = ("R", "G", "B")
    spec.attribute("compression", "zip")
    for key, value in attrs.items():
        spec.attribute(key, value)
    tmp = f"{path}.tmp.exr"
    out = oiio.ImageOutput.create(tmp)
    if out is None or not out.open(tmp, spec) or not out.write_image(rgb) or not out.close():
        fail(path, f"cannot write: {oiio.geterror()}")
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", help="Mitsuba 3 scene.xml (from mixmc-scene export --mitsuba)")
    ap.add_argument("-o", "--output", help="output EXR (RGB float32); omitted: render and time only")
    ap.add_argument("--variant", help="Mitsuba variant [default: llvm_ad_rgb if it loads, else scalar_rgb]")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel [64]")
    ap.add_argument("--seed", type=int, default=0, help="seed [0]")
    ap.add_argument("--max-depth", type=int, help="largest depth, mixmc's convention (Mitsuba's is +1) [the scene's]")
    ap.add_argument("--runs", type=int, default=1, help="render this many times (seeds seed, seed+1, ...); the EXR is the first [1]")
    ap.add_argument("--pass-samples", type=int, default=1 << 22, help="most path samples per Mitsuba render call [4194304]")
    ap.add_argument("--json", action="store_true", help="print the result as one JSON object")
    ap.add_argument("--llvm-lanes", type=int, help="compile the llvm_* kernels for 8 or 16 lanes [the host's widest]")
    a = ap.parse_args()
    if a.spp < 1 or a.runs < 1 or a.pass_samples < 1 or a.seed < 0:
        fail("arguments", "--spp, --runs and --pass-samples must be positive, --seed non-negative")
    if a.max_depth is not None and a.max_depth < 0:
        fail("--max-depth", f"{a.max_depth} must be >= 0")
    if not os.path.isfile(a.scene):
        fail(a.scene, "no such file")
    if a.llvm_lanes is not None:
        check_llvm_lanes(a.llvm_lanes)

    import mitsuba as mi

    variant = pick_variant(mi, a.variant)
    if a.llvm_lanes is not None:
        set_llvm_lanes(a.llvm_lanes, variant)
    t0 = time.perf_counter()
    try:
        scene = mi.load_file(a.scene)
    except Exception as e:
        fail(a.scene, f"Mitsuba cannot load it: {str(e).strip().splitlines()[-1]}")
    load_s = time.perf_counter() - t0
    integrator = scene.integrator()
    if a.max_depth is not None:
        integrator = mi.load_dict({"type": "path", "max_depth": a.max_depth + 1})
    width, height = (int(v) for v in scene.sensors()[0].film().crop_size())

    seconds, cpu_seconds, first = [], [], None
    for r in range(a.runs):
        rgb, s, cpu = render(mi, scene, integrator, width, height, a.spp, a.seed + r, a.pass_samples)
        seconds.append(s)
        cpu_seconds.append(cpu)
        if first is None:
            first = rgb
    samples = width * height * a.spp
    if a.output:
        write_exr(a.output, first, {
            "mixmc.tool": "mitsuba_render.py",
            "mitsuba.variant": variant,
            "mitsuba.version": mi.__version__,
            "mixmc.spp": float(a.spp),
            "mixmc.seed": float(a.seed),
            "mixmc.seconds": float(seconds[0]),
        })
    result = {
        "variant": variant, "llvm_lanes": a.llvm_lanes, "mitsuba": mi.__version__, "width": width, "height": height,
        "spp": a.spp, "samples": samples, "load_seconds": load_s, "seconds": seconds, "cpu_seconds": cpu_seconds,
        "samples_per_second": [samples / s for s in seconds], "output": a.output,
    }
    if a.json:
        print(json.dumps(result))
    else:
        for r, s in enumerate(seconds):
            print(f"{a.output or a.scene}: {variant} run {r + 1}/{a.runs}: {width}x{height} x {a.spp} spp "
                  f"in {s:.3f} s = {samples / s / 1e6:.3f} M samples/s ({cpu_seconds[r]:.2f} CPU s)")
        print(f"(scene load {load_s:.3f} s, not counted)")


if __name__ == "__main__":
    main()
