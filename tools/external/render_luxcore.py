"""Render a scene exported by `mixmc-scene export --mitsuba DIR` in LuxCore (`pyluxcore`, in
tools/.venv-lux, installed with --no-deps beside numpy < 2.3) to one file per AOV in a directory:
the layout `mixmc-mask --layout luxcore` and `mixmc-composite --layout luxcore` read.

Unbiased, matched settings: PATHCPU with the RANDOM sampler, no variance clamping, uniform light
choice (the DLS cache would bias), a 1-pixel box filter, no denoiser or image pipeline on the
AOVs; matte = Lambert, glass with our IOR (`glass`: exact Fresnel), mirror; emitters are
LuxCore's one-sided mesh lights with gain 1 (radiance = our emission). Glossy (GGX without
Fresnel, Mitsuba's `material=none`) has no LuxCore twin and is refused.

    tools/.venv-lux/bin/python tools/external/render_luxcore.py EXPORTED_DIR OUT_DIR --spp 64 --seed 1

Every AOV the `luxcore` layout reads is requested as a film output, and the script fails when a
file did not appear (docs/external.md): mixmc-mask can go without an INDIRECT_* file, but
mixmc-composite cannot.
"""

import os
import time
import sys
from pathlib import Path

import numpy as np  # before pyluxcore: its wheel expects numpy to be loaded
import pyluxcore

sys.path.insert(0, str(Path(__file__).resolve().parent))
import exported  # noqa: E402

AOVS = [
    "RADIANCE_GROUP",
    "EMISSION",
    "DIRECT_DIFFUSE",
    "DIRECT_GLOSSY",
    "INDIRECT_DIFFUSE",
    "INDIRECT_GLOSSY",
    "INDIRECT_SPECULAR",
    "DEPTH",
    "SHADING_NORMAL",
]


def rgb(c):
    return f"{c[0]} {c[1]} {c[2]}"


def scene_props(ex):
    p = []
    c = ex.camera
    p += [
        'scene.camera.type = "perspective"',
        f"scene.camera.lookat.orig = {rgb(c.origin)}",
        f"scene.camera.lookat.target = {rgb(c.target)}",
        f"scene.camera.up = {rgb(c.up)}",
        f"scene.camera.fieldofview = {c.fov_y}",
    ]
    for i, sh in enumerate(ex.shapes):
        m = ex.materials[sh.material]
        name = f"scene.materials.shape{i}"
        if m.kind == "diffuse":
            p += [f'{name}.type = "matte"', f"{name}.kd = {rgb(m.color)}"]
        elif m.kind == "mirror":
            p += [f'{name}.type = "mirror"', f"{name}.kr = {rgb(m.color)}"]
        elif m.kind == "glass":
            p += [
                f'{name}.type = "glass"',
                f"{name}.kr = 1 1 1",
                f"{name}.kt = {rgb(m.color)}",
                f"{name}.interiorior = {m.ior}",
                f"{name}.exteriorior = 1",
            ]
        else:
            raise SystemExit(f"render_luxcore.py: material {sh.material}: {m.kind} has no LuxCore twin")
        p.append(f"{name}.id = {ex.material_order.index(sh.material)}")
        if sh.emission is not None:
            p += [
                f"{name}.emission = {rgb(sh.emission)}",
                f"{name}.emission.gain = 1 1 1",
                f"{name}.emission.power = 0",
                f"{name}.emission.efficency = 0",
                f"{name}.emission.normalizebycolor = 0",
            ]
        p += [f'scene.objects.shape{i}.shape = "mesh{i}"', f'scene.objects.shape{i}.material = "shape{i}"']
    return pyluxcore.Properties().SetFromString("\n".join(p))


def config_props(ex, spp, seed, threads):
    p = [
        'renderengine.type = "PATHCPU"',
        'sampler.type = "RANDOM"',
        f"renderengine.seed = {seed}",
        f"native.threads.count = {threads}",
        f"batch.haltspp = {spp}",
        f"film.width = {ex.camera.width}",
        f"film.height = {ex.camera.height}",
        'film.filter.type = "BOX"',
        "film.filter.width = 0.5",
        f"path.pathdepth.total = {ex.max_depth}",
        f"path.pathdepth.diffuse = {ex.max_depth}",
        f"path.pathdepth.glossy = {ex.max_depth}",
        f"path.pathdepth.specular = {ex.max_depth}",
        "path.clamping.variance.maxvalue = 0",
        'lightstrategy.type = "UNIFORM"',
        "path.forceblackbackground.enable = 1",
        'film.imagepipelines.0.0.type = "NOP"',
    ]
    for i, aov in enumerate(AOVS):
        p += [f'film.outputs.{i}.type = "{aov}"', f'film.outputs.{i}.filename = "{aov}.exr"']
    p += [f'film.outputs.{len(AOVS)}.type = "MATERIAL_ID"', f'film.outputs.{len(AOVS)}.filename = "MATERIAL_ID.png"']
    return pyluxcore.Properties().SetFromString("\n".join(p))


def main():
    a = exported.parse_args(__doc__, "directory for the AOV files")
    ex = exported.load(a.exported)
    # LuxCore's log goes to stderr; with a callback that printed nothing, the session never
    # finished here.
    pyluxcore.Init(lambda msg: print(msg, file=sys.stderr, flush=True))
    scene = pyluxcore.Scene()
    for i, sh in enumerate(ex.shapes):
        scene.DefineMesh(f"mesh{i}", list(sh.positions), list(sh.triangles), None, None, None, None)
    scene.Parse(scene_props(ex))
    config = pyluxcore.RenderConfig(config_props(ex, a.spp, a.seed, a.threads), scene)
    session = pyluxcore.RenderSession(config)
    out = Path(a.output)
    out.mkdir(parents=True, exist_ok=True)
    # LuxCore renames files it would overwrite to *.bak: start from an empty directory.
    for f in out.iterdir():
        f.unlink()
    session.Start()
    # Halt conditions (batch.haltspp) are only checked when the statistics are updated.
    while not session.HasDone():
        time.sleep(0.1)
        session.UpdateStats()
    session.Stop()
    # Film.Save writes each output's file name relative to the working directory.
    cwd = os.getcwd()
    os.chdir(out)
    try:
        session.GetFilm().Save()
    finally:
        os.chdir(cwd)
    wanted = [f"{aov}.exr" for aov in AOVS] + ["MATERIAL_ID.png"]
    lacks = [f for f in wanted if not (out / f).is_file()]
    if lacks:
        print(f"render_luxcore.py: {out}: LuxCore wrote no {', '.join(lacks)}", file=sys.stderr, flush=True)
    # pyluxcore 2.11.2 crashes (SIGSEGV) in its destructors at exit; the files are written.
    os._exit(1 if lacks else 0)


if __name__ == "__main__":
    main()
