#!/usr/bin/env python3
"""Ground truth for the Mitsuba import's camera (issue 25): load each Mitsuba 3 XML scene given with
Mitsuba and print, as one JSON list a line, the ray of its first sensor through the centre of each of
the film's four corner pixels and of its middle pixel: [x, y, ox, oy, oz, dx, dy, dz] each, with
x, y the raster position (pixels of size 1, y down) that mixmc's `Camera::ray_dir` takes.

    tools/.venv/bin/python tools/mitsuba_camera_rays.py scene.xml [more.xml ...]
"""
import json
import sys

import mitsuba as mi


def main():
    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Error)
    for path in sys.argv[1:]:
        print(json.dumps(rays(mi.load_file(path).sensors()[0])))


def rays(sensor):
    w, h = (int(v) for v in sensor.film().crop_size())
    out = []
    for px, py in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1), (w // 2, h // 2)]:
        x, y = px + 0.5, py + 0.5
        ray, _ = sensor.sample_ray(0.0, 0.5, [x / w, y / h], [0.5, 0.5])
        out.append([x, y] + [float(ray.o[i]) for i in range(3)] + [float(ray.d[i]) for i in range(3)])
    return out


if __name__ == "__main__":
    main()
