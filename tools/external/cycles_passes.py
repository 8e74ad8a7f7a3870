"""Which passes does Blender Cycles really write? Renders a tiny scene (a diffuse floor, a ceiling
light, and a glossy and a glass cube where the variant names them) through render_cycles.build,
which requests every pass the `cycles` layout reads, and prints for each variant the requested
passes that the multilayer EXR's headers lack (docs/external.md has the table).

    tools/.venv-bpy/bin/python tools/external/cycles_passes.py [--size 8] [--spp 4] [--keep DIR]

Besides the BSDF kinds, the variants put the cubes behind the camera, turn Blender's compositor on
(Render Layers wired to the group output, as a default .blend has), set bounce limits to 0, save
through `Render Result.save_render` instead of `write_still`, and leave two Color passes
unrequested.
"""

import argparse
import sys
import tempfile
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import exported  # noqa: E402
import render_cycles  # noqa: E402


def quad(z, half, emission=None, material="floor"):
    """A horizontal square at height z, facing up (down when `emission` is set: a ceiling light)."""
    p = [(-half, -half, z), (half, -half, z), (half, half, z), (-half, half, z)]
    tris = [(0, 1, 2), (0, 2, 3)] if emission is None else [(0, 2, 1), (0, 3, 2)]
    return exported.Shape(p, tris, material, emission)


def block(material, x, y=0.0):
    """An axis-aligned unit cube centred at (x, y, 0.5)."""
    p = [(x + dx - 0.5, y + dy - 0.5, dz) for dz in (0, 1) for dy in (0, 1) for dx in (0, 1)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = [t for a, b, c, d in faces for t in ((a, b, c), (a, c, d))]
    return exported.Shape(p, tris, material)


KINDS = {
    "diffuse": exported.Material("diffuse", (0.7, 0.7, 0.7)),
    "glossy": exported.Material("glossy", (0.9, 0.8, 0.7), alpha=0.05),
    "glass": exported.Material("glass", (1.0, 1.0, 1.0), ior=1.5),
}


def scene(kinds, size, hidden):
    cam = exported.Camera((0.0, -6.0, 3.0), (0.0, 0.0, 0.5), (0.0, 0.0, 1.0), 50.0, size, size)
    ex = exported.Exported(cam, max_depth=6)
    for k in ["diffuse", *kinds]:
        ex.materials[k] = KINDS[k]
        ex.material_order.append(k)
    ex.materials["light"] = KINDS["diffuse"]
    ex.material_order.append("light")
    ex.shapes.append(quad(0.0, 4.0, material="diffuse"))
    ex.shapes.append(quad(4.0, 1.0, emission=(8.0, 8.0, 8.0), material="light"))
    for i, k in enumerate(kinds):
        # Behind the camera (y < −6) the block is in the scene but no camera path can see it.
        ex.shapes.append(block(k, 1.5 * i - 0.75, -9.0 if hidden else 0.0))
    return ex


PASSES = [
    f"{c} {t}" for c in ("Diffuse", "Glossy", "Transmission") for t in ("Direct", "Indirect", "Color")
] + ["Emission", "Environment", "Depth", "Normal", "Material Index", "Combined"]


def compositor_on(sc):
    """Blender 5: a compositing node group with Render Layers → Group Output, as a default file has."""
    tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
    rl = tree.nodes.new("CompositorNodeRLayers")
    out = tree.nodes.new("NodeGroupOutput")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    tree.links.new(rl.outputs["Image"], out.inputs[0])
    sc.compositing_node_group = tree
    sc.render.use_compositing = True


def no_bounces(kind):
    def tweak(sc):
        setattr(sc.cycles, f"{kind}_bounces", 0)
    return tweak


def fewer_total(sc):
    sc.cycles.max_bounces = 0


def colors_off(*kinds):
    """Direct and Indirect requested, Color not: Cycles still divides by its (internal) Color pass."""

    def tweak(sc):
        for k in kinds:
            setattr(sc.view_layers[0], f"use_pass_{k}_color", False)

    return tweak


# name: (BSDF kinds besides the diffuse floor, block hidden behind the camera, scene tweak, how to save)
VARIANTS = {
    "diffuse": ((), False, None, "write_still"),
    "diffuse+glossy": (("glossy",), False, None, "write_still"),
    "diffuse+glass": (("glass",), False, None, "write_still"),
    "diffuse+glossy+glass": (("glossy", "glass"), False, None, "write_still"),
    "diffuse+glossy+glass, blocks unseen": (("glossy", "glass"), True, None, "write_still"),
    "diffuse+glossy+glass, compositor on": (("glossy", "glass"), False, compositor_on, "write_still"),
    "diffuse+glossy+glass, glossy_bounces 0": (("glossy", "glass"), False, no_bounces("glossy"), "write_still"),
    "diffuse+glossy+glass, transmission_bounces 0": (
        ("glossy", "glass"),
        False,
        no_bounces("transmission"),
        "write_still",
    ),
    "diffuse+glossy+glass, max_bounces 0": (("glossy", "glass"), False, fewer_total, "write_still"),
    "diffuse+glossy+glass, Render Result.save_render": (("glossy", "glass"), False, None, "save_render"),
    "diffuse+glossy+glass, glossy and transmission Color not requested": (
        ("glossy", "glass"),
        False,
        colors_off("glossy", "transmission"),
        "write_still",
    ),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=8)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--keep", help="write each variant's EXR into this directory")
    a = ap.parse_args()
    outdir = Path(a.keep) if a.keep else Path(tempfile.mkdtemp())
    outdir.mkdir(parents=True, exist_ok=True)
    for i, (name, (kinds, hidden, tweak, save)) in enumerate(VARIANTS.items()):
        sc = render_cycles.build(scene(list(kinds), a.size, hidden), a.spp, 1, 1)
        if tweak:
            tweak(sc)
        path = (outdir / f"variant{i}.exr").resolve()
        sc.render.filepath = str(path)
        sc.render.use_file_extension = False
        if save == "write_still":
            bpy.ops.render.render(write_still=True)
        else:
            bpy.ops.render.render()
            bpy.data.images["Render Result"].save_render(str(path))
        have = render_cycles.multilayer_passes(path)
        lacks = [p for p in PASSES if p not in have]
        print(f"{path.name} ({name}): lacks {', '.join(lacks) if lacks else 'nothing'}", flush=True)


if __name__ == "__main__":
    main()
