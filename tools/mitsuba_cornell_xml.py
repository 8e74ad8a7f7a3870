#!/usr/bin/env python3
"""Write Mitsuba 3's built-in Cornell box (`mitsuba.cornell_box()`) as a Mitsuba XML scene, with
Mitsuba's own XML writer (`mitsuba.parser.write_string`), for the import tests (issue 25):

    tools/.venv/bin/python tools/mitsuba_cornell_xml.py --size 128 -o fixtures/mitsuba/cornell-box.xml
    tools/.venv/bin/python tools/mitsuba_cornell_xml.py --size 128 --sphere -o fixtures/mitsuba/cornell-sphere.xml

`--size N` sets the film to N x N (the dict's is 256 x 256); `--sphere` puts a smooth dielectric
sphere (`int_ior` "bk7", radius 0.3) where the small box stands. Everything else is the dict as
Mitsuba builds it: its gaussian film filter, `fov_axis` "smaller", rectangles and cubes placed
by transforms that the writer decomposes into scale, rotate, translate (or a matrix).
"""
import argparse
import os

import mitsuba as mi


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", required=True, help="output XML")
    ap.add_argument("--size", type=int, default=256, help="film width and height [256]")
    ap.add_argument("--sphere", action="store_true", help="a glass sphere in place of the small box")
    a = ap.parse_args()
    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Error)
    d = mi.cornell_box()
    d["sensor"]["film"]["width"] = a.size
    d["sensor"]["film"]["height"] = a.size
    if a.sphere:
        del d["small-box"]
        d["glass"] = {"type": "dielectric", "int_ior": "bk7", "ext_ior": "air"}
        d["glass-sphere"] = {
            "type": "sphere",
            "center": [0.335, -0.7, 0.38],
            "radius": 0.3,
            "bsdf": {"type": "ref", "id": "glass"},
        }
    state = mi.parser.parse_dict(mi.parser.ParserConfig("scalar_rgb"), d)
    text = mi.parser.write_string(state)
    mi.load_string(text)  # Mitsuba itself must read what it wrote
    os.makedirs(os.path.dirname(os.path.abspath(a.output)), exist_ok=True)
    with open(a.output, "w") as f:
        # No "--" inside an XML comment: the options are spelt out in words.
        note = f"written by tools/mitsuba_cornell_xml.py with size {a.size}{' and sphere' if a.sphere else ''}"
        f.write(text.replace("<scene ", f"<!-- {note}, Mitsuba {mi.__version__} -->\n<scene ", 1))


if __name__ == "__main__":
    main()
