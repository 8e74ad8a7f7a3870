"""Render a scene exported by `mixmc-scene export --mitsuba DIR` with Mitsuba 3's `aov` integrator
(its path tracer inside, plus depth, shading normal and shape index) and, with the same seed, a
`max_depth=2` path tracer: the direct part (our depth ≤ 1) that `--layout mitsuba` reads from the
second file. Both renders use the same seed, so their camera rays and first segments coincide.

    tools/.venv/bin/python tools/external/render_mitsuba.py EXPORTED_DIR OUT.exr OUT-direct.exr --spp 64 --seed 1

`load_file(…, optimize=False)` keeps one shape per PLY, so `shape_index` is one id per object
(Mitsuba has no material-id AOV).
"""

import argparse
import xml.etree.ElementTree as ET
from pathlib import Path

import mitsuba as mi


def render(scene, integrator, spp, seed, path):
    mi.render(scene, integrator=integrator, spp=spp, seed=seed)
    scene.sensors()[0].film().bitmap().write(str(path))


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
    render(scene, aov, a.spp, a.seed, a.output)
    render(scene, mi.load_dict({"type": "path", "max_depth": 2}), a.spp, a.seed, a.direct)


if __name__ == "__main__":
    main()
