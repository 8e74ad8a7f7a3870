"""Read a scene written by `mixmc-scene export --mitsuba DIR` (scene.xml + binary PLY) into plain
Python, so the Cycles and LuxCore scripts build the same triangles, camera and materials as ours.

Only what the exporter writes is understood; anything else is an error, never a silent guess."""

import argparse
import math
import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Material:
    kind: str  # diffuse | mirror | glossy | glass
    color: tuple  # albedo / reflectance / transmittance
    alpha: float = 0.0  # GGX alpha (glossy)
    ior: float = 1.0  # glass


@dataclass
class Shape:
    positions: list  # [(x, y, z)]
    triangles: list  # [(i, j, k)]
    material: str  # bsdf id
    emission: tuple = None  # RGB radiance of the front side, or None


@dataclass
class Camera:
    origin: tuple
    target: tuple
    up: tuple
    fov_y: float
    width: int
    height: int

    def basis(self):
        """(right, up, forward) as in src/camera.rs: right = forward × up, up = right × forward."""
        f = _norm(_sub(self.target, self.origin))
        r = _norm(_cross(f, self.up))
        return r, _cross(r, f), f


@dataclass
class Exported:
    camera: Camera
    max_depth: int  # ours (Mitsuba's max_depth − 1)
    materials: dict = field(default_factory=dict)  # id -> Material
    material_order: list = field(default_factory=list)  # ids in file order (our material index)
    shapes: list = field(default_factory=list)


def _sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _norm(a):
    n = math.sqrt(sum(x * x for x in a))
    return tuple(x / n for x in a)


def _vec(text):
    return tuple(float(v) for v in text.split(","))


def read_ply(path):
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().split("\n")
    nv = int(next(l for l in header if l.startswith("element vertex")).split()[2])
    nf = int(next(l for l in header if l.startswith("element face")).split()[2])
    pos = [struct.unpack_from("<3f", data, end + 12 * i) for i in range(nv)]
    off = end + 12 * nv
    tris = []
    for _ in range(nf):
        if data[off] != 3:
            raise ValueError(f"{path}: only triangles are supported")
        tris.append(struct.unpack_from("<3i", data, off + 1))
        off += 13
    return pos, tris


def _material(el):
    t = el.get("type")
    if t == "twosided":
        el = el.find("bsdf")
        t = el.get("type")
    vals = {c.get("name"): c.get("value") for c in el}
    if t == "diffuse":
        return Material("diffuse", _vec(vals["reflectance"]))
    if t == "conductor":
        return Material("mirror", _vec(vals["specular_reflectance"]))
    if t == "roughconductor":
        return Material("glossy", _vec(vals["specular_reflectance"]), alpha=float(vals["alpha"]))
    if t == "dielectric":
        return Material("glass", _vec(vals["specular_transmittance"]), ior=float(vals["int_ior"]))
    raise ValueError(f"unsupported bsdf type {t}")


def load(directory):
    directory = Path(directory)
    root = ET.parse(directory / "scene.xml").getroot()
    integ = root.find("integrator")
    max_depth = int(integ.find("integer").get("value")) - 1
    s = root.find("sensor")
    look = s.find("transform/lookat")
    film = {c.get("name"): c.get("value") for c in s.find("film")}
    cam = Camera(
        _vec(look.get("origin")),
        _vec(look.get("target")),
        _vec(look.get("up")),
        float(s.find("float[@name='fov']").get("value")),
        int(film["width"]),
        int(film["height"]),
    )
    out = Exported(cam, max_depth)
    for b in root.findall("bsdf"):
        out.materials[b.get("id")] = _material(b)
        out.material_order.append(b.get("id"))
    for sh in root.findall("shape"):
        pos, tris = read_ply(directory / sh.find("string[@name='filename']").get("value"))
        em = sh.find("emitter")
        emission = _vec(em.find("rgb").get("value")) if em is not None else None
        out.shapes.append(Shape(pos, tris, sh.find("ref").get("id"), emission))
    return out


def parse_args(doc, output_help, extra=()):
    """The command line the render scripts share: EXPORTED_DIR OUTPUT [--spp] [--seed] [--threads],
    and a script's own `extra` options as (flag, argparse keywords)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    for flag, kw in extra:
        ap.add_argument(flag, **kw)
    ap.add_argument("exported", help="directory written by mixmc-scene export --mitsuba")
    ap.add_argument("output", help=output_help)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=1)
    return ap.parse_args()
