#!/usr/bin/env python3
"""The glTF asset set of scenes/assets/, made with another tool than lumo: Blender (the `bpy`
module, 5.0) builds each scene and its own glTF exporter writes it, textures included.

    pip install bpy numpy        # bpy 5.0.1 is about 370 MB
    python3 tools/assets/make_assets.py            # writes scenes/assets/*.glb

The scenes exercise what issue 48 asks of glTF assets as authored, each lit by an emissive
panel (emission × KHR_materials_emissive_strength: a radiance, which needs no unit conversion
between renderers) and seen by an exported perspective camera:
  - textured-spheres: a checker base-colour texture on the floor, a rough dielectric, a
    polished metal and a sphere whose metallicRoughness texture switches between the two
    ends in stripes;
  - foliage: alpha-masked leaves (an RGBA texture, alphaMode MASK) and a half-transparent
    pane (alphaMode BLEND) in front of coloured blocks;
  - character: a tube skinned to two bones and carrying a morph target, both animated; its
    last pose (held after the last key) is what tools/assets/compare_cycles.py renders;
  - glass: a glass ball with KHR_materials_transmission, ior and volume (attenuation), which
    the exporter writes from the Principled BSDF's transmission and a Volume Absorption node;
  - diffuse-floor and plastic-floor: a rough floor alone, without and with its dielectric
    specular layer, which separate the renderers' agreement on light and units from their
    material models.
Deterministic in content: the same geometry, materials and textures every run (no random
numbers); the exporter may order a mesh's vertices differently from run to run.
"""
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "..", "scenes", "assets")


def fresh():
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy


def principled(name, base=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5):
    import bpy

    m = bpy.data.materials.new(name)
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*base, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    return m, p


def image(name, rgba, non_color=False):
    """A packed image from an (H, W, 4) array, rows top to bottom."""
    import bpy

    h, w = rgba.shape[:2]
    img = bpy.data.images.new(name, w, h, alpha=True)
    # The colour space first: setting it afterwards drops the pixels just written.
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    img.pixels = np.ascontiguousarray(rgba[::-1], dtype=np.float32).ravel().tolist()
    img.file_format = "PNG"
    img.pack()
    return img


def texture_node(mat, img):
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.interpolation = "Linear"
    return tex


def add(obj_op, material=None, **kw):
    import bpy

    obj_op(**kw)
    ob = bpy.context.active_object
    if material is not None:
        ob.data.materials.append(material)
    return ob


def shade_smooth(ob):
    for poly in ob.data.polygons:
        poly.use_smooth = True


def emissive_panel(size, location, strength, color=(1.0, 0.95, 0.85)):
    """A square facing down (−Z) emitting `color` × `strength` radiance."""
    import bpy

    m, p = principled("lamp", base=(0.0, 0.0, 0.0), roughness=1.0)
    p.inputs["Emission Color"].default_value = (*color, 1.0)
    p.inputs["Emission Strength"].default_value = strength
    p.inputs["Specular IOR Level"].default_value = 0.0
    ob = add(bpy.ops.mesh.primitive_plane_add, m, size=size, location=location)
    ob.rotation_euler = (math.pi, 0.0, 0.0)  # its normal now points down
    ob.name = "lamp"
    return ob


def camera(location, target, fov_deg=40.0):
    import bpy
    from mathutils import Vector

    cam = bpy.data.cameras.new("camera")
    cam.sensor_fit = "VERTICAL"
    cam.angle = math.radians(fov_deg)
    ob = bpy.data.objects.new("camera", cam)
    bpy.context.scene.collection.objects.link(ob)
    ob.location = location
    ob.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = ob
    sc = bpy.context.scene
    sc.render.resolution_x = sc.render.resolution_y = 256
    return ob


def checker(n=256, squares=8, a=0.8, b=0.15):
    y, x = np.mgrid[0:n, 0:n] * squares // n
    v = np.where((x + y) % 2 == 0, a, b).astype(np.float32)
    rgba = np.stack([v, v * 0.9 + 0.05, v * 0.7 + 0.1, np.ones_like(v)], axis=-1)
    return rgba


def floor(size=8.0, texture=True):
    import bpy

    m, p = principled("floor", base=(0.6, 0.6, 0.6), roughness=0.9)
    if texture:
        tex = texture_node(m, image("checker", checker()))
        m.node_tree.links.new(tex.outputs["Color"], p.inputs["Base Color"])
    ob = add(bpy.ops.mesh.primitive_plane_add, m, size=size, location=(0, 0, 0))
    ob.name = "floor"
    return ob


def export(name, animations=False):
    import bpy

    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, f"{name}.glb")
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format="GLB",
        export_cameras=True,
        export_lights=False,
        export_animations=animations,
        # One glTF animation holding the bones' and the morph weights' channels, as authored
        # (the default writes one animation per action, and players pick one).
        export_animation_mode="ACTIVE_ACTIONS",
        export_apply=False,
        export_yup=True,
    )
    print(f"wrote {os.path.relpath(path)}", file=sys.stderr)
    return path


def textured_spheres():
    bpy = fresh()
    floor()
    dielectric, _ = principled("red plastic", base=(0.8, 0.12, 0.08), roughness=0.45)
    metal, _ = principled("gold", base=(1.0, 0.77, 0.34), metallic=1.0, roughness=0.3)
    for mat, x in [(dielectric, -1.3), (metal, 0.0)]:
        ob = add(bpy.ops.mesh.primitive_uv_sphere_add, mat, radius=0.55, location=(x, 0, 0.55),
                 segments=64, ring_count=32)
        shade_smooth(ob)
    # Stripes along v: metal (B = 1) and polished (G = 0.15) against dielectric and rough.
    n = 64
    stripe = (np.arange(n)[:, None] // 8) % 2 == 0
    rgba = np.zeros((n, n, 4), np.float32)
    rgba[..., 1] = np.where(stripe, 0.15, 0.8)
    rgba[..., 2] = np.where(stripe, 1.0, 0.0)
    rgba[..., 3] = 1.0
    mr, p = principled("striped metal", base=(0.9, 0.9, 0.92), metallic=1.0, roughness=1.0)
    tex = texture_node(mr, image("metal-rough", rgba, non_color=True))
    sep = mr.node_tree.nodes.new("ShaderNodeSeparateColor")
    mr.node_tree.links.new(tex.outputs["Color"], sep.inputs["Color"])
    mr.node_tree.links.new(sep.outputs["Green"], p.inputs["Roughness"])
    mr.node_tree.links.new(sep.outputs["Blue"], p.inputs["Metallic"])
    ob = add(bpy.ops.mesh.primitive_uv_sphere_add, mr, radius=0.55, location=(1.3, 0, 0.55),
             segments=64, ring_count=32)
    shade_smooth(ob)
    emissive_panel(2.0, (0.0, -0.5, 3.5), 6.0)
    camera((0.0, -5.0, 2.2), (0.0, 0.0, 0.45), 40.0)
    return export("textured-spheres")


def leaf(n=128):
    """An RGBA leaf: a pointed ellipse, opaque inside, a lighter midrib, transparent outside."""
    y, x = (np.mgrid[0:n, 0:n] + 0.5) / n * 2.0 - 1.0
    width = 0.55 * np.sqrt(np.clip(1.0 - y * y, 0.0, 1.0)) * (1.0 - 0.35 * y)
    inside = np.abs(x) < width
    rib = np.abs(x) < 0.03
    rgba = np.zeros((n, n, 4), np.float32)
    rgba[..., 0] = np.where(rib, 0.45, 0.12)
    rgba[..., 1] = np.where(rib, 0.6, 0.45)
    rgba[..., 2] = np.where(rib, 0.2, 0.08)
    rgba[..., 3] = inside.astype(np.float32)
    return rgba


def foliage():
    bpy = fresh()
    floor(texture=False)
    # Leaves: alpha from the texture through Math:Round, which Blender's exporter writes as
    # alphaMode MASK with alphaCutoff 0.5.
    m, p = principled("leaf", roughness=0.6)
    tex = texture_node(m, image("leaf", leaf()))
    rnd = m.node_tree.nodes.new("ShaderNodeMath")
    rnd.operation = "ROUND"
    m.node_tree.links.new(tex.outputs["Color"], p.inputs["Base Color"])
    m.node_tree.links.new(tex.outputs["Alpha"], rnd.inputs[0])
    m.node_tree.links.new(rnd.outputs["Value"], p.inputs["Alpha"])
    for k in range(7):
        a = k * 2.0 * math.pi / 7
        ob = add(bpy.ops.mesh.primitive_plane_add, m, size=0.9,
                 location=(0.9 * math.cos(a) - 0.6, 0.6 * math.sin(a), 0.8 + 0.12 * k))
        ob.rotation_euler = (1.1 + 0.15 * math.sin(3 * a), 0.0, a)
    # Coloured blocks seen through a half-transparent pane (constant alpha 0.5: BLEND).
    for i, (col, x) in enumerate([((0.7, 0.15, 0.1), 0.9), ((0.1, 0.3, 0.7), 1.6)]):
        b, _ = principled(f"block{i}", base=col, roughness=0.5)
        add(bpy.ops.mesh.primitive_cube_add, b, size=0.6, location=(x, 0.6, 0.3))
    pane, pp = principled("pane", base=(0.9, 0.9, 0.6), roughness=0.7)
    pp.inputs["Alpha"].default_value = 0.5
    ob = add(bpy.ops.mesh.primitive_plane_add, pane, size=1.4, location=(1.25, -0.2, 0.7))
    ob.rotation_euler = (math.pi / 2, 0.0, 0.0)
    emissive_panel(2.0, (0.0, 0.0, 3.5), 6.0)
    camera((0.2, -5.4, 2.3), (0.2, 0.0, 0.6), 42.0)
    return export("foliage")


def character():
    """A tube on two bones with a morph target; both animated, the pose held from 1 s on."""
    bpy = fresh()
    floor(texture=False)
    skin, _ = principled("skin", base=(0.75, 0.45, 0.35), roughness=0.55)
    tube = add(bpy.ops.mesh.primitive_cylinder_add, skin, vertices=32, radius=0.25, depth=2.0,
               location=(0.0, 0.0, 1.0))
    tube.name = "tube"
    # Cut the tube into rings so that it bends smoothly.
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=15)
    bpy.ops.object.mode_set(mode="OBJECT")
    shade_smooth(tube)
    # Morph target: the middle swells.
    tube.shape_key_add(name="Basis")
    swell = tube.shape_key_add(name="swell")
    for v, kv in zip(tube.data.vertices, swell.data):
        z = v.co.z  # object space, −1..1
        f = 1.0 + 0.8 * math.exp(-((z - 0.1) / 0.3) ** 2)
        kv.co = (v.co.x * f, v.co.y * f, v.co.z)
    arm_data = bpy.data.armatures.new("rig")
    rig = bpy.data.objects.new("rig", arm_data)
    bpy.context.scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    lower = arm_data.edit_bones.new("lower")
    lower.head, lower.tail = (0, 0, 0), (0, 0, 1.0)
    upper = arm_data.edit_bones.new("upper")
    upper.head, upper.tail = (0, 0, 1.0), (0, 0, 2.0)
    upper.parent = lower
    bpy.ops.object.mode_set(mode="OBJECT")
    # Weights: a smooth hand-over around the joint at height 1.
    lo, up = tube.vertex_groups.new(name="lower"), tube.vertex_groups.new(name="upper")
    for v in tube.data.vertices:
        h = v.co.z + 1.0  # world height (the tube's origin is at 1)
        w = min(max((h - 0.7) / 0.6, 0.0), 1.0)
        if w < 1.0:
            lo.add([v.index], 1.0 - w, "REPLACE")
        if w > 0.0:
            up.add([v.index], w, "REPLACE")
    mod = tube.modifiers.new("rig", "ARMATURE")
    mod.object = rig
    tube.parent = rig
    sc = bpy.context.scene
    sc.render.fps = 24
    pb = rig.pose.bones["upper"]
    pb.rotation_mode = "XYZ"
    for frame, angle, weight in [(1, 0.0, 0.0), (25, 1.0, 1.0)]:
        pb.rotation_euler = (angle, 0.0, 0.0)
        pb.keyframe_insert("rotation_euler", frame=frame)
        swell.value = weight
        swell.keyframe_insert("value", frame=frame)
    sc.frame_start, sc.frame_end = 1, 25
    emissive_panel(2.0, (0.0, -0.8, 3.8), 6.0)
    camera((3.6, -3.6, 2.0), (0.0, 0.0, 1.0), 40.0)
    return export("character", animations=True)


def material_output_group(thickness):
    """The "glTF Material Output" node group Blender's exporter reads the volume thickness from."""
    import bpy

    g = bpy.data.node_groups.get("glTF Material Output")
    if g is None:
        g = bpy.data.node_groups.new("glTF Material Output", "ShaderNodeTree")
        g.interface.new_socket("Thickness", in_out="INPUT", socket_type="NodeSocketFloat")
    return g


def glass():
    bpy = fresh()
    floor()
    m, p = principled("green glass", base=(1.0, 1.0, 1.0), roughness=0.0)
    p.inputs["Transmission Weight"].default_value = 1.0
    p.inputs["IOR"].default_value = 1.5
    nt = m.node_tree
    absorb = nt.nodes.new("ShaderNodeVolumeAbsorption")
    absorb.inputs["Color"].default_value = (0.35, 0.8, 0.45, 1.0)
    absorb.inputs["Density"].default_value = 1.0 / 0.6  # attenuationDistance 0.6
    nt.links.new(absorb.outputs["Volume"], nt.nodes["Material Output"].inputs["Volume"])
    grp = nt.nodes.new("ShaderNodeGroup")
    grp.node_tree = material_output_group(1.0)
    grp.inputs["Thickness"].default_value = 1.0
    ob = add(bpy.ops.mesh.primitive_uv_sphere_add, m, radius=0.6, location=(0.0, 0.0, 0.6),
             segments=64, ring_count=32)
    shade_smooth(ob)
    emissive_panel(1.5, (0.0, 0.8, 3.2), 10.0)
    camera((0.0, -4.2, 1.8), (0.0, 0.0, 0.5), 38.0)
    return export("glass")


def floor_only(name, specular):
    """A rough floor under the lamp, nothing else: with `specular` 0 a pure Lambertian (the
    check that light, camera and units agree), with 0.5 (F0 = 0.04) the dielectric layer alone,
    where glTF renderers' diffuse-under-specular weights differ (docs/gltf.md)."""
    bpy = fresh()
    m, p = principled("floor", base=(0.6, 0.6, 0.6), roughness=0.9)
    p.inputs["Specular IOR Level"].default_value = specular
    add(bpy.ops.mesh.primitive_plane_add, m, size=8.0, location=(0, 0, 0))
    emissive_panel(2.0, (0.0, 0.0, 3.5), 6.0)
    camera((0.2, -5.4, 2.3), (0.2, 0.0, 0.6), 42.0)
    return export(name)


SCENES = {
    "textured-spheres": textured_spheres,
    "foliage": foliage,
    "character": character,
    "glass": glass,
    "diffuse-floor": lambda: floor_only("diffuse-floor", 0.0),
    "plastic-floor": lambda: floor_only("plastic-floor", 0.5),
}

if __name__ == "__main__":
    for w in sys.argv[1:] or list(SCENES):
        SCENES[w]()
