"""Render a scene exported by `mixmc-scene export --mitsuba DIR` in Blender Cycles (`bpy` from PyPI,
in tools/.venv-bpy) to a multilayer EXR with the passes `mixmc-mask --layout cycles` and
`mixmc-composite --layout cycles` read.

Unbiased, matched settings: path tracing with no clamping, no denoising, no adaptive sampling, no
light tree, no filter glossy; a 1-pixel box filter (ours); bounce limits = our max_depth − 1 (Cycles
counts bounces after the first hit); Lambert diffuse, sharp glass with our IOR, GGX roughness
√α (Cycles squares it); emitters only on their front side (the winding's normal), as ours.

    tools/.venv-bpy/bin/python tools/external/render_cycles.py EXPORTED_DIR OUT.exr --spp 64 --seed 1

The written file is read back and checked for every pass the `cycles` layout reads: Blender writes
a requested pass always (zero where the scene has no such BSDF) and an unrequested one never, not
even a Color pass its Direct and Indirect were divided by (tools/external/cycles_passes.py). `--omit
glossy_color` (a `use_pass_*` name without the prefix, repeatable) leaves a pass unrequested, to
make such a file on purpose; the check then expects it missing.
"""

import math
import sys
from pathlib import Path

import bpy
from mathutils import Matrix

sys.path.insert(0, str(Path(__file__).resolve().parent))
import exported  # noqa: E402


def node_material(name, mat, emission, pass_index):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.pass_index = pass_index
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    if mat.kind == "diffuse":
        bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
        bsdf.inputs["Roughness"].default_value = 0.0
    elif mat.kind in ("mirror", "glossy"):
        bsdf = nt.nodes.new("ShaderNodeBsdfGlossy")
        bsdf.distribution = "GGX"
        bsdf.inputs["Roughness"].default_value = math.sqrt(mat.alpha)
    elif mat.kind == "glass":
        bsdf = nt.nodes.new("ShaderNodeBsdfGlass")
        bsdf.distribution = "GGX"
        bsdf.inputs["Roughness"].default_value = 0.0
        bsdf.inputs["IOR"].default_value = mat.ior
    else:
        raise ValueError(mat.kind)
    bsdf.inputs["Color"].default_value = (*mat.color, 1.0)
    shader = bsdf.outputs[0]
    if emission is not None:
        # Front side only: the backfacing side gets a black emission.
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (*emission, 1.0)
        em.inputs["Strength"].default_value = 1.0
        black = nt.nodes.new("ShaderNodeEmission")
        black.inputs["Strength"].default_value = 0.0
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(geo.outputs["Backfacing"], mix.inputs[0])
        nt.links.new(em.outputs[0], mix.inputs[1])
        nt.links.new(black.outputs[0], mix.inputs[2])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(shader, add.inputs[0])
        nt.links.new(mix.outputs[0], add.inputs[1])
        shader = add.outputs[0]
        m.cycles.emission_sampling = "FRONT"
    nt.links.new(shader, out.inputs["Surface"])
    return m


# The view layer's passes the `cycles` layout reads (src/layout.rs), and the pass each writes.
PASSES = {
    "use_pass_combined": "Combined",
    "use_pass_diffuse_direct": "Diffuse Direct",
    "use_pass_diffuse_indirect": "Diffuse Indirect",
    "use_pass_diffuse_color": "Diffuse Color",
    "use_pass_glossy_direct": "Glossy Direct",
    "use_pass_glossy_indirect": "Glossy Indirect",
    "use_pass_glossy_color": "Glossy Color",
    "use_pass_transmission_direct": "Transmission Direct",
    "use_pass_transmission_indirect": "Transmission Indirect",
    "use_pass_transmission_color": "Transmission Color",
    "use_pass_emit": "Emission",
    "use_pass_environment": "Environment",
    "use_pass_z": "Depth",
    "use_pass_normal": "Normal",
    "use_pass_material_index": "Material Index",
}


def multilayer_passes(path):
    """Pass names in a multilayer EXR's headers (`ViewLayer.<pass>.<channel>`): the headers of a
    multi-part file follow the 8-byte magic and version, each a run of attributes (name, type,
    size, value) ended by a NUL, the last header by one more."""
    data = Path(path).read_bytes()
    multipart = bool(data[5] & 0x10)  # version flag bit 12
    pos, names = 8, set()
    while True:
        while data[pos] != 0:
            name_end = data.index(b"\0", pos)
            type_end = data.index(b"\0", name_end + 1)
            size = int.from_bytes(data[type_end + 1 : type_end + 5], "little")
            value = data[type_end + 5 : type_end + 5 + size]
            if data[pos:name_end] == b"channels":
                for ch in value.split(b"\0"):
                    parts = ch.decode("latin-1").split(".")
                    if len(parts) >= 3 and parts[0] == "ViewLayer":
                        names.add(parts[1])
            pos = type_end + 5 + size
        pos += 1
        if not multipart or data[pos] == 0:
            return names


def build(ex, spp, seed, threads, omit=()):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for i, sh in enumerate(ex.shapes):
        mesh = bpy.data.meshes.new(f"mesh{i}")
        mesh.from_pydata(sh.positions, [], sh.triangles)
        mesh.update()
        index = ex.material_order.index(sh.material)
        mat = node_material(f"shape{i}", ex.materials[sh.material], sh.emission, index + 1)
        mesh.materials.append(mat)
        obj = bpy.data.objects.new(f"obj{i}", mesh)
        scene.collection.objects.link(obj)

    c = ex.camera
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(c.fov_y)
    cam_data.clip_start = 1e-4
    cam_data.clip_end = 1e6
    cam = bpy.data.objects.new("camera", cam_data)
    r, u, f = c.basis()
    # Blender cameras look down their local −Z with +Y up.
    cam.matrix_world = Matrix(
        [
            [r[0], u[0], -f[0], c.origin[0]],
            [r[1], u[1], -f[1], c.origin[1]],
            [r[2], u[2], -f[2], c.origin[2]],
            [0, 0, 0, 1],
        ]
    )
    scene.collection.objects.link(cam)
    scene.camera = cam

    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world

    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = spp
    cy.seed = seed
    cy.use_animated_seed = False
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.use_light_tree = False
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    bounces = ex.max_depth - 1
    cy.max_bounces = bounces
    cy.diffuse_bounces = bounces
    cy.glossy_bounces = bounces
    cy.transmission_bounces = bounces
    cy.transparent_max_bounces = bounces
    cy.volume_bounces = 0
    scene.render.resolution_x = c.width
    scene.render.resolution_y = c.height
    scene.render.resolution_percentage = 100
    scene.render.threads_mode = "FIXED"
    scene.render.threads = threads
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"

    vl = scene.view_layers[0]
    for p in PASSES:
        setattr(vl, p, p.removeprefix("use_pass_") not in omit)
    s = scene.render.image_settings
    s.media_type = "MULTI_LAYER_IMAGE"  # Blender 5: multilayer EXR is its own media type
    s.file_format = "OPEN_EXR_MULTILAYER"
    s.color_depth = "32"
    s.exr_codec = "ZIP"
    return scene


def main():
    a = exported.parse_args(
        __doc__,
        "multilayer EXR to write",
        [("--omit", dict(action="append", default=[], help="leave use_pass_OMIT unrequested"))],
    )
    unknown = [o for o in a.omit if f"use_pass_{o}" not in PASSES]
    if unknown:
        sys.exit(f"render_cycles.py: --omit {unknown[0]}: not one of {', '.join(p[9:] for p in PASSES)}")
    ex = exported.load(a.exported)
    scene = build(ex, a.spp, a.seed, a.threads, a.omit)
    scene.render.filepath = str(Path(a.output).resolve())
    scene.render.use_file_extension = False
    bpy.ops.render.render(write_still=True)
    have = multilayer_passes(a.output)
    expected = {name for p, name in PASSES.items() if p.removeprefix("use_pass_") not in a.omit}
    if have != expected:
        sys.exit(
            f"render_cycles.py: {a.output}: Blender wrote the passes {sorted(have)}, "
            f"expected {sorted(expected)}"
        )


if __name__ == "__main__":
    main()
