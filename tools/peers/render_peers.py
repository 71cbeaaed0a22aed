#!/usr/bin/env python3
"""lumo's path tracer beside Mitsuba 3, Cycles and LuxCore on the same scene files.

    apt-get install -y libllvm19        # Mitsuba's llvm_ad_rgb variant (compare_mitsuba.py)
    pip install mitsuba bpy pyluxcore numpy
    cargo build --release -p lumo-cli
    python3 tools/peers/render_peers.py --scenes scenes/cornell.xml --res 256 --spp 64

Every renderer gets the same Mitsuba 3 XML file: lumo and Mitsuba read it themselves; Cycles
(`bpy`) and LuxCore (`pyluxcore`) get the meshes, diffuse materials, area lights, constant
environment and camera that `xml_scene.py` reads from it (a scene using anything else is
refused by name, never rendered as something else). Same resolution, samples per pixel and
path length (Mitsuba's `max_depth`; Cycles' bounces = max_depth − 2; LuxCore's total depth =
max_depth − 1), a one-pixel box filter, no denoiser, no clamping, no adaptive sampling, all
cores (--threads).

For each scene and renderer, alternating the renderers --repeats times so all see the same
load:
  * time: the median wall time of one render at --spp. lumo: the whole `lumo render`
    process (parse, BVH, render, image write). Mitsuba: `mi.render` after an untimed warm-up
    render (the JIT compiles then), image read back. Cycles: `bpy.ops.render.render` (scene
    sync, BVH, render, EXR write), after an untimed 1-spp render. LuxCore: from
    `RenderSession.Start` until it reports done (preprocessing, BVH, render).
  * samples/s = width × height × spp / time.
  * mean: per-channel image mean, against Mitsuba's (the models agree for diffuse surfaces
    and area lights; where not, docs/results/peers.md says how).
  * noise: two renders with different seeds, relative variance per pixel
    (a − b)² / 2 / (ref² + 0.01), averaged (ref: Mitsuba's mean of its two renders): the
    relMSE one render has if it is unbiased. relMSE × time is the inverse efficiency; the
    ratio of a peer's to lumo's is the relMSE ratio at equal time.
Each renderer runs in its own subprocess (`--worker NAME`): bpy, pyluxcore and Dr.Jit bring
their own copies of common libraries and do not share a process well. The table goes to
stdout as Markdown.
"""

import argparse
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "scripts"))

from run_peers import read_pfm  # noqa: E402  (the PFM reader the denoiser comparison uses)

RENDERERS = ["lumo", "mitsuba", "cycles", "luxcore"]


# ---------------------------------------------------------------- workers (one per process)


def work_lumo(a):
    out = Path(a.out).with_suffix(".pfm")
    cmd = [a.lumo, "render", a.scene, "--pipeline", "none", "-D", f"res={a.res}",
           "--spp", str(a.spp), "--seed", str(a.seed), "--threads", str(a.threads),
           "-o", str(out)]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, check=True, capture_output=True, text=True)
    t = time.perf_counter() - t0
    # lumo's own "done in X s" is the render alone (no parse, BVH build or image write): the
    # part Mitsuba's timed `mi.render` covers; kept beside the whole process's time.
    done = re.findall(r"done in ([0-9.]+) s", r.stdout + r.stderr)
    print(json.dumps({"render_only": float(done[-1]) if done else None}))
    return t, read_pfm(out)


def work_mitsuba(a):
    from compare_mitsuba import ensure_llvm_path

    ensure_llvm_path()
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(a.threads)
    scene = mi.load_file(a.scene, res=str(a.res))
    np.array(mi.render(scene, spp=a.spp, seed=a.seed + 1000))  # JIT warm-up, untimed
    t0 = time.perf_counter()
    img = np.array(mi.render(scene, spp=a.spp, seed=a.seed))
    return time.perf_counter() - t0, img[..., :3]


def cycles_settings(sc, max_depth, seed, threads, size):
    """Cycles set up to compare with lumo: CPU, no adaptive sampling, denoiser or clamping, a
    one-pixel box filter, linear 32-bit EXR output, and bounces = Mitsuba's `max_depth` − 2
    (the mapping that agrees within 0.1 % on the Cornell box; unlimited for −1). Shared with
    tools/assets/compare_cycles.py."""
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = seed
    bounces = 1024 if max_depth < 0 else max(max_depth - 2, 0)
    for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
              "volume_bounces", "transparent_max_bounces"):
        setattr(cy, k, bounces)
    cy.caustics_reflective = cy.caustics_refractive = True
    cy.blur_glossy = 0.0
    cy.sample_clamp_direct = cy.sample_clamp_indirect = 0.0
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    sc.render.threads_mode = "FIXED"
    sc.render.threads = threads
    sc.render.resolution_x, sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.view_settings.view_transform = "Standard"


def cycles_mesh(mesh):
    """A Blender mesh of `mesh`'s triangles (smooth where it has normals, and with its texture
    coordinates as a UV layer), filled through `foreach_set`: `from_pydata` takes minutes for
    a million triangles."""
    import bpy

    me = bpy.data.meshes.new(mesh.name)
    n, m = len(mesh.positions), len(mesh.faces)
    me.vertices.add(n)
    me.vertices.foreach_set("co", mesh.positions.astype(np.float32).ravel())
    me.loops.add(3 * m)
    me.loops.foreach_set("vertex_index", mesh.faces.astype(np.int32).ravel())
    me.polygons.add(m)
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * m, 3, dtype=np.int32))
    me.update(calc_edges=True)
    me.validate()
    if mesh.normals is not None:
        me.shade_smooth()
    if mesh.uvs is not None:
        uv = me.uv_layers.new(name="UVMap")
        uv.data.foreach_set("uv", mesh.uvs[mesh.faces.ravel()].astype(np.float32).ravel())
    return me


def cycles_material(mesh):
    """The Cycles node tree of an `xml_scene.Material`: Diffuse (a colour or an sRGB image
    texture), Metallic with the physical conductor Fresnel (eta, k), or Glass; GGX with
    Cycles' roughness = √α (Cycles squares it), both sides shaded as Mitsuba does (an opaque
    one-sided BSDF is black behind; glass is two-sided)."""
    import bpy

    mt = mesh.material
    mat = bpy.data.materials.new(mesh.name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    if mt.kind == "conductor":
        bsdf = nt.nodes.new("ShaderNodeBsdfMetallic")
        bsdf.distribution = "GGX"
        bsdf.fresnel_type = "PHYSICAL_CONDUCTOR"
        bsdf.inputs["IOR"].default_value = mt.eta
        bsdf.inputs["Extinction"].default_value = mt.k
        bsdf.inputs["Roughness"].default_value = mt.alpha ** 0.5
    elif mt.kind == "dielectric":
        bsdf = nt.nodes.new("ShaderNodeBsdfGlass")
        bsdf.distribution = "GGX"
        bsdf.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        bsdf.inputs["IOR"].default_value = mt.ior
        bsdf.inputs["Roughness"].default_value = mt.alpha ** 0.5
    else:
        bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
        bsdf.inputs["Roughness"].default_value = 0.0
        if mt.texture is not None:
            tex = nt.nodes.new("ShaderNodeTexImage")
            tex.image = bpy.data.images.load(mt.texture)
            tex.interpolation = "Linear"
            tex.extension = "REPEAT"
            nt.links.new(tex.outputs["Color"], bsdf.inputs["Color"])
        else:
            bsdf.inputs["Color"].default_value = (*mt.reflectance, 1.0)
    front = bsdf.outputs["BSDF"]
    if mt.radiance is not None:
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (*mt.radiance, 1.0)
        em.inputs["Strength"].default_value = 1.0
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(bsdf.outputs["BSDF"], add.inputs[0])
        nt.links.new(em.outputs["Emission"], add.inputs[1])
        front = add.outputs["Shader"]
        mat.cycles.emission_sampling = "FRONT"
    # Mitsuba's opaque BSDFs and area lights are one-sided: black behind.
    back = nt.nodes.new("ShaderNodeBsdfDiffuse")
    back.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
    nt.links.new(front, mix.inputs[1])
    nt.links.new((bsdf if mt.two_sided else back).outputs["BSDF"], mix.inputs[2])
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    return mat


def cycles_sun(sc, direction, irradiance):
    """A Cycles sun lamp of zero angle (a directional light): strength in W/m² is the
    irradiance on a surface facing it, as Mitsuba's `directional`; it shines along its −z."""
    import bpy
    from mathutils import Matrix

    light = bpy.data.lights.new("sun", "SUN")
    light.angle = 0.0
    e = max(irradiance)
    light.energy = e
    light.color = tuple(c / e for c in irradiance)
    z = -np.asarray(direction, float)
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, np.cross(z, x), z
    obj = bpy.data.objects.new("sun", light)
    obj.matrix_world = Matrix(m.tolist())
    sc.collection.objects.link(obj)


def work_cycles(a):
    import math

    import bpy
    import xml_scene

    s = xml_scene.read_scene(a.scene, res=a.res)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    cycles_settings(sc, s.max_depth, a.seed, a.threads, (s.camera.width, s.camera.height))
    cy = sc.cycles
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    env = s.environment or (0.0, 0.0, 0.0)
    bg.inputs["Color"].default_value = (*env, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    sc.world = world
    cam = bpy.data.cameras.new("camera")
    cam.sensor_fit = "HORIZONTAL"
    cam.angle = math.radians(s.camera.fov_x)
    cam_obj = bpy.data.objects.new("camera", cam)
    o, t, up = (np.array(v, float) for v in (s.camera.origin, s.camera.target, s.camera.up))
    fwd = (t - o) / np.linalg.norm(t - o)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(right, fwd), -fwd, o
    from mathutils import Matrix

    cam_obj.matrix_world = Matrix(m.tolist())
    sc.collection.objects.link(cam_obj)
    sc.camera = cam_obj
    if s.sun is not None:
        cycles_sun(sc, *s.sun)
    for mesh in s.meshes:
        me = cycles_mesh(mesh)
        me.materials.append(cycles_material(mesh))
        obj = bpy.data.objects.new(mesh.name, me)
        sc.collection.objects.link(obj)
    path = str(Path(a.out).with_suffix(".exr"))
    sc.render.filepath = path
    cy.samples = 1
    bpy.ops.render.render(write_still=True)  # kernels and scene set up, untimed
    cy.samples = a.spp
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    t = time.perf_counter() - t0
    img = bpy.data.images.load(path)
    px = np.array(img.pixels[:], dtype=np.float32).reshape(img.size[1], img.size[0], 4)
    return t, px[::-1, :, :3]  # Blender's rows run bottom to top


def work_luxcore(a):
    import pyluxcore
    import xml_scene

    s = xml_scene.read_scene(a.scene, res=a.res)
    if s.sun is not None:
        raise xml_scene.Unsupported("LuxCore: directional lights are not mapped")
    for mesh in s.meshes:
        if mesh.material.kind != "diffuse" or mesh.material.texture is not None:
            # LuxCore's rough metal and glass use Schlick's microfacet distribution, not GGX,
            # and its image textures a 2.2 gamma, not sRGB: they would render other materials.
            raise xml_scene.Unsupported(
                f"LuxCore: {mesh.material.kind} {mesh.name!r}"
                f"{' with a texture' if mesh.material.texture else ''} is not mapped")
    pyluxcore.Init(lambda msg: None)
    scene = pyluxcore.Scene()
    p = pyluxcore.Properties()
    c = s.camera
    fmt = lambda v: [float(x) for x in v]  # noqa: E731
    p.Set(pyluxcore.Property("scene.camera.type", "perspective"))
    p.Set(pyluxcore.Property("scene.camera.lookat.orig", fmt(c.origin)))
    p.Set(pyluxcore.Property("scene.camera.lookat.target", fmt(c.target)))
    p.Set(pyluxcore.Property("scene.camera.up", fmt(c.up)))
    # LuxCore's field of view spans the image's shorter side.
    import math

    fov = c.fov_x if c.width <= c.height else math.degrees(
        2 * math.atan(math.tan(math.radians(c.fov_x) / 2) * c.height / c.width))
    p.Set(pyluxcore.Property("scene.camera.fieldofview", fov))
    if s.environment is not None:
        p.Set(pyluxcore.Property("scene.lights.env.type", "constantinfinite"))
        p.Set(pyluxcore.Property("scene.lights.env.color", fmt(s.environment)))
    for i, mesh in enumerate(s.meshes):
        verts = [tuple(v) for v in mesh.positions.tolist()]
        faces = [tuple(f) for f in mesh.faces.tolist()]
        normals = None if mesh.normals is None else [tuple(v) for v in mesh.normals.tolist()]
        scene.DefineMesh(f"mesh{i}", verts, faces, normals, None, None, None)
        base = f"scene.materials.mat{i}"
        p.Set(pyluxcore.Property(f"{base}.type", "matte"))
        p.Set(pyluxcore.Property(f"{base}.kd", fmt(mesh.material.reflectance)))
        if mesh.material.radiance is not None:
            p.Set(pyluxcore.Property(f"{base}.emission", fmt(mesh.material.radiance)))
        p.Set(pyluxcore.Property(f"scene.objects.obj{i}.shape", f"mesh{i}"))
        p.Set(pyluxcore.Property(f"scene.objects.obj{i}.material", f"mat{i}"))
    scene.Parse(p)
    depth = 1024 if s.max_depth < 0 else max(s.max_depth - 1, 1)
    cfg = pyluxcore.Properties()
    for k, v in [
        ("renderengine.type", "PATHCPU"), ("sampler.type", "SOBOL"),
        ("renderengine.seed", a.seed + 1),
        ("path.pathdepth.total", depth), ("path.pathdepth.diffuse", depth),
        ("path.pathdepth.glossy", depth), ("path.pathdepth.specular", depth),
        ("path.clamping.variance.maxvalue", 0.0),
        ("film.width", c.width), ("film.height", c.height),
        ("film.filter.type", "BOX"), ("film.filter.width", 0.5),
        ("batch.haltspp", a.spp), ("native.threads.count", a.threads),
        ("film.outputs.0.type", "RGB"), ("film.outputs.0.filename", "unused.exr"),
    ]:
        cfg.Set(pyluxcore.Property(k, v))
    config = pyluxcore.RenderConfig(cfg, scene)
    session = pyluxcore.RenderSession(config)
    t0 = time.perf_counter()
    session.Start()
    while not session.HasDone():
        time.sleep(0.005)
        session.UpdateStats()
    t = time.perf_counter() - t0
    session.Stop()
    buf = np.zeros(c.width * c.height * 3, dtype=np.float32)
    session.GetFilm().GetOutputFloat(pyluxcore.FilmOutputType.RGB, buf)
    return t, buf.reshape(c.height, c.width, 3)[::-1]  # LuxCore's rows run bottom to top


def worker(a):
    import xml_scene

    try:
        t, img = globals()[f"work_{a.worker}"](a)
    except xml_scene.Unsupported as e:
        print(json.dumps({"refused": str(e)}))
        sys.stdout.flush()
        os._exit(0)
    np.save(a.out + ".npy", np.asarray(img, np.float32))
    print(json.dumps({"time": t}))
    sys.stdout.flush()
    os._exit(0)  # bpy and pyluxcore may crash in their exit handlers; the result is written


# ---------------------------------------------------------------- driver


def run(a, name, scene, spp, seed, out):
    cmd = [sys.executable, __file__, "--worker", name, "--scene", str(scene), "--res",
           str(a.res), "--spp", str(spp), "--seed", str(seed), "--threads", str(a.threads),
           "--lumo", a.lumo, "--out", out]
    r = subprocess.run(cmd, check=True, capture_output=True, text=True)
    lines = [json.loads(x) for x in r.stdout.splitlines() if x.startswith("{")]
    if "refused" in lines[-1]:
        return None, lines[-1]["refused"], None
    extra = {k: v for d in lines[:-1] for k, v in d.items()}
    return lines[-1]["time"], np.load(out + ".npy"), extra.get("render_only")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="*", default=[str(ROOT / "scenes" / "cornell.xml")])
    ap.add_argument("--renderers", nargs="*", default=RENDERERS)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--lumo", default=str(ROOT / "target" / "release" / "lumo"))
    ap.add_argument("--worker", choices=RENDERERS)
    ap.add_argument("--scene")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out")
    a = ap.parse_args()
    if a.worker:
        return worker(a)
    rows, refused, render_only = [], [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for scene in a.scenes:
            name = Path(scene).stem
            times = {r: [] for r in a.renderers}
            imgs = {r: [] for r in a.renderers}
            alone = []
            active = list(a.renderers)
            for rep in range(a.repeats):
                for r in list(active):
                    t, img, only = run(a, r, scene, a.spp, rep, f"{tmp}/{name}-{r}-{rep}")
                    if t is None:
                        refused.append(f"{name}: {img}")
                        active.remove(r)
                        print(f"{name} {r}: refused: {img}", file=sys.stderr, flush=True)
                        continue
                    times[r].append(t)
                    if only is not None:
                        alone.append(only)
                    if rep < 2:
                        imgs[r].append(img)
                    print(f"{name} {r} run {rep}: {t:.3f} s, mean {img.mean(axis=(0, 1))}",
                          file=sys.stderr, flush=True)
            if alone:
                render_only[name] = statistics.median(alone)
            base = "mitsuba" if "mitsuba" in active else active[0]
            ref = 0.5 * (imgs[base][0] + imgs[base][1])
            samples = a.res * a.res * a.spp
            for r in active:
                t = statistics.median(times[r])
                x, y = imgs[r]
                noise = float(np.mean((x - y) ** 2 / 2 / (ref**2 + 0.01)))
                mean = 0.5 * (x.mean(axis=(0, 1)) + y.mean(axis=(0, 1)))
                rows.append(dict(scene=name, renderer=r, time=t, ksps=samples / t / 1e3,
                                 mean=mean, base_mean=ref.mean(axis=(0, 1)), noise=noise,
                                 ineff=noise * t))
    load = os.getloadavg()
    print(f"{a.res}×{a.res}, {a.spp} spp, {a.threads} threads, median of {a.repeats} "
          f"alternating runs; {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs, load average {load[0]:.1f} at the end.\n")
    print("| scene | renderer | time (s) | ksamples/s | lumo's speed × | mean vs Mitsuba "
          "(R, G, B) | relMSE of one render | relMSE at equal time / lumo's |")
    print("|---|---|---:|---:|---:|---|---:|---:|")
    for row in rows:
        lumo = next(x for x in rows if x["scene"] == row["scene"] and x["renderer"] == "lumo")
        diff = ", ".join(f"{100 * (m / b - 1):+.2f} %" for m, b in zip(row["mean"],
                                                                       row["base_mean"]))
        print(f"| {row['scene']} | {row['renderer']} | {row['time']:.3f} | {row['ksps']:.0f} | "
              f"{row['time'] / lumo['time']:.2f} | {diff} | {row['noise']:.3e} | "
              f"{row['ineff'] / lumo['ineff']:.2f} |")
    if render_only:
        print("\nlumo's render alone (its own `done in`, without parsing, BVH build and image "
              "write: what Mitsuba's timed `mi.render` covers), median: " + ", ".join(
                  f"{k} {v:.3f} s" for k, v in render_only.items()))
    for line in refused:
        print(f"\nNot compared (refused by the scene reader, never rendered as something "
              f"else): {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
