"""Render a scene exported by `mixmc-scene export --mitsuba DIR` with Mitsuba 3's `aov` integrator
(its path tracer inside, plus depth, shading normal and shape index) and, with the same seed, a
`max_depth=2` path tracer: the direct part (our depth ≤ 1) that `--layout mitsuba` reads from the
second file. Both renders use the same seed, so their camera rays and first segments coincide.

    tools/.venv/bin/python tools/external/render_mitsuba.py EXPORTED_DIR OUT.exr OUT-direct.exr --spp 64 --seed 1

`load_file(…, optimize=False)` keeps one shape per PLY, so `shape_index` is one id per object
(Mitsuba has no material-id AOV). Both files are read back and checked for every channel the
`mitsuba` layout reads (src/layout.rs, docs/external.md): a missing one fails here, not later in
mixmc-mask or mixmc-composite.
"""

import argparse
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import mitsuba as mi


# The channels `--layout mitsuba` reads from each file.
AOV_CHANNELS = ["image.R", "image.G", "image.B", "depth.T", "normal.X", "normal.Y", "normal.Z", "shape.I"]
DIRECT_CHANNELS = ["R", "G", "B"]


def render(scene, integrator, spp, seed, path, channels):
    mi.render(scene, integrator=integrator, spp=spp, seed=seed)
    scene.sensors()[0].film().bitmap().write(str(path))
    written = mi.Bitmap(str(path))
    have = {written.struct_()[i].name for i in range(written.channel_count())}
    lacks = [c for c in channels if c not in have]
    if lacks:
        sys.exit(
            f"render_mitsuba.py: {path}: Mitsuba wrote no {', '.join(lacks)} (has {', '.join(sorted(have))})"
        )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("exported", help="directory written by mixmc-scene export --mitsuba")
    ap.add_argument("output", help="aov EXR to write (image.R/G/B, depth.T, normal.X/Y/Z, shape.I)")
    ap.add_argument("direct", help="EXR of the max_depth=2 render to write (R,G,B)")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    mi.set_variant("scalar_rgb")
    xml = Path(a.exported) / "scene.xml"
    scene = mi.load_file(str(xml), optimize=False)
    full_depth = int(ET.parse(xml).getroot().find("integrator/integer").get("value"))
    aov = mi.load_dict(
        {
            "type": "aov",
            "aovs": "depth:depth,normal:sh_normal,shape:shape_index",
            "image": {"type": "path", "max_depth": full_depth},
        }
    )
    render(scene, aov, a.spp, a.seed, a.output, AOV_CHANNELS)
    direct = mi.load_dict({"type": "path", "max_depth": 2})
    render(scene, direct, a.spp, a.seed, a.direct, DIRECT_CHANNELS)


if __name__ == "__main__":
    main()
