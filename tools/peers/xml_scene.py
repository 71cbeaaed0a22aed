"""A small subset of Mitsuba 3's XML scene format, read into world-space triangle meshes, so
that renderers without a Mitsuba loader (Cycles through `bpy`, LuxCore through `pyluxcore`)
can be given the very scene file lumo and Mitsuba read.

What is read: `<default>` and `$name` substitution (overridable), `perspective` sensors
(`fov`, `fov_axis` x/y/smaller/larger, `to_world` as `lookat` or a transform), the film's
width and height, the integrator's `max_depth`; shapes `rectangle`, `cube`, `sphere` (center
and radius, or a unit sphere under `to_world`; tessellated), `obj` and `ply` files (triangles
and positions only, through a minimal reader: OBJ `v`/`f`, binary or ASCII PLY with float
vertices, and the PLY's `u`/`v` where it has them); `to_world` transforms built from
`translate`, `scale`, `rotate`, `matrix`, `lookat`, applied in order; BSDFs `diffuse` (rgb or
a float reflectance, or a `bitmap` texture: sRGB file, default filtering), `conductor` and
`roughconductor` (rgb `eta` and `k`, `ggx` with one `alpha`), `dielectric` and
`roughdielectric` (numeric `int_ior` / `ext_ior`, `ggx` with one `alpha`), `twosided` around
one of them, `ref` by id; `area` emitters with rgb radiance; a `constant` environment; one
`directional` emitter (`direction`, rgb `irradiance`). Anything else raises `Unsupported`
naming the element, so a comparison never runs on a scene that was silently read as
something else.
"""

import math
import re
import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np


class Unsupported(Exception):
    """An element of the scene file that this reader does not translate."""


@dataclass
class Material:
    """What a peer needs to build the surface. `kind` is "diffuse" (Lambertian
    `reflectance`, or the sRGB image file `texture` when not None), "conductor" (complex index
    `eta` + i·`k` per RGB channel) or "dielectric" (relative index `ior`); `alpha` is the GGX
    roughness of the last two (0: smooth). `two_sided`: Mitsuba's `twosided` (else an opaque
    surface's back is black); `radiance`: what it emits from its front side (None: not an
    emitter)."""

    reflectance: tuple
    radiance: tuple = None
    two_sided: bool = False
    kind: str = "diffuse"
    texture: object = None
    eta: tuple = None
    k: tuple = None
    alpha: float = 0.0
    ior: float = None


@dataclass
class Mesh:
    """World-space triangles: positions (N, 3), faces (M, 3) indices, per-vertex normals
    (N, 3) or None for flat shading, per-vertex texture coordinates (N, 2) or None."""

    name: str
    positions: np.ndarray
    faces: np.ndarray
    normals: object
    material: Material
    uvs: object = None


@dataclass
class Camera:
    """A pinhole camera: position, look-at target, up, and the full field of view in degrees
    along the horizontal axis (converted from Mitsuba's `fov_axis`)."""

    origin: tuple
    target: tuple
    up: tuple
    fov_x: float
    width: int
    height: int


@dataclass
class Scene:
    """Everything a peer renders: camera, meshes, a constant environment (or None) and the
    path length limit as Mitsuba counts it (max_depth, −1 = unlimited), and a directional light
    (or None)."""

    camera: Camera
    meshes: list = field(default_factory=list)
    environment: object = None
    max_depth: int = -1
    sun: object = None  # (direction the light travels, rgb irradiance) or None


def _floats(text):
    return [float(v) for v in re.split(r"[,\s]+", text.strip()) if v]


def _rotation(axis, angle_deg):
    x, y, z = np.asarray(axis, float) / np.linalg.norm(axis)
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    t = 1 - c
    m = np.eye(4)
    m[:3, :3] = [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
    return m


def _lookat(origin, target, up):
    o, t, u = (np.asarray(v, float) for v in (origin, target, up))
    d = t - o
    d /= np.linalg.norm(d)
    left = np.cross(u, d)
    left /= np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, o
    return m


class _Reader:
    def __init__(self, path, overrides):
        self.path = Path(path)
        self.defaults = dict(overrides)
        self.overrides = set(overrides)
        self.ids = {}

    def attr(self, el, name, default=None):
        v = el.get(name, default)
        if isinstance(v, str):
            v = re.sub(r"\$(\w+)", lambda m: str(self.defaults[m.group(1)]), v)
        return v

    def fail(self, el, what):
        raise Unsupported(f"{self.path}: <{el.tag} {dict(el.attrib)}>: {what}")

    def transform(self, el):
        m = np.eye(4)
        for op in el:
            a = lambda n, d=None: self.attr(op, n, d)  # noqa: E731
            if op.tag == "translate":
                t = np.eye(4)
                if a("value"):
                    t[:3, 3] = _floats(a("value"))
                else:
                    t[:3, 3] = [float(a("x", 0)), float(a("y", 0)), float(a("z", 0))]
            elif op.tag == "scale":
                if a("value"):
                    v = _floats(a("value"))
                    v = v * 3 if len(v) == 1 else v
                else:
                    v = [float(a("x", 1)), float(a("y", 1)), float(a("z", 1))]
                t = np.diag(v + [1.0])
            elif op.tag == "rotate":
                axis = _floats(a("value")) if a("value") else [
                    float(a("x", 0)), float(a("y", 0)), float(a("z", 0))]
                t = _rotation(axis, float(a("angle")))
            elif op.tag == "matrix":
                t = np.array(_floats(a("value"))).reshape(4, 4)
            elif op.tag == "lookat":
                t = _lookat(_floats(a("origin")), _floats(a("target")),
                            _floats(a("up", "0, 1, 0")))
            else:
                self.fail(op, "transform operation not read")
            m = t @ m
        return m

    def props(self, el, nested=()):
        """Named child values: floats, integers, strings, booleans, rgb, points, transforms.
        Child elements named in `nested` are left to the caller; any other (a `<texture>`, a
        `<spectrum>`, ...) is refused."""
        out = {}
        for c in el:
            if c.tag in nested:
                continue
            name = c.get("name")
            if c.tag in ("float", "integer"):
                out[name] = float(self.attr(c, "value"))
            elif c.tag in ("string", "boolean"):
                out[name] = self.attr(c, "value")
            elif c.tag == "rgb":
                v = _floats(self.attr(c, "value"))
                out[name] = tuple(v * 3 if len(v) == 1 else v)
            elif c.tag in ("point", "vector"):
                if c.get("value") is not None:
                    out[name] = tuple(_floats(self.attr(c, "value")))
                else:
                    out[name] = tuple(float(self.attr(c, k, 0)) for k in "xyz")
            elif c.tag == "transform":
                out[name] = self.transform(c)
            else:
                self.fail(c, "value type not read")
        return out

    def bsdf(self, el):
        """The Material of a BSDF element or reference (one-sided unless `twosided`)."""
        if el.tag == "ref":
            return self.ids[el.get("id")]
        kind = el.get("type")
        if kind == "twosided":
            inner = [c for c in el if c.tag in ("bsdf", "ref")]
            if len(inner) != 1:
                self.fail(el, "twosided with two BSDFs is not read")
            return replace(self.bsdf(inner[0]), two_sided=True)
        if kind == "diffuse":
            tex = el.find("texture[@name='reflectance']")
            if tex is not None:
                if tex.get("type") != "bitmap" or len(tex) != 1:
                    self.fail(tex, "only a bitmap with its filename alone is read")
                file = self.path.parent / self.attr(tex.find("string[@name='filename']"), "value")
                return Material((0.5, 0.5, 0.5), texture=str(file))
            r = self.props(el).get("reflectance", (0.5, 0.5, 0.5))
            return Material(r if isinstance(r, tuple) else (r, r, r))
        p = self.props(el)
        if kind in ("roughconductor", "roughdielectric"):
            if p.get("distribution") != "ggx" or "alpha" not in p:
                self.fail(el, "only ggx with one alpha is read")
        alpha = p.get("alpha", 0.0) if kind.startswith("rough") else 0.0
        if kind in ("conductor", "roughconductor"):
            if not (isinstance(p.get("eta"), tuple) and isinstance(p.get("k"), tuple)):
                self.fail(el, "a conductor needs rgb eta and k (no material presets)")
            return Material((1.0, 1.0, 1.0), kind="conductor", eta=p["eta"], k=p["k"],
                            alpha=alpha)
        if kind in ("dielectric", "roughdielectric"):
            ior = p.get("int_ior", 1.5049)
            ext = p.get("ext_ior", 1.000277)
            if isinstance(ior, str) or isinstance(ext, str):
                self.fail(el, "only numeric int_ior / ext_ior are read")
            return Material((1.0, 1.0, 1.0), kind="dielectric", ior=ior / ext, alpha=alpha,
                            two_sided=True)
        self.fail(el, "BSDF type not read")

    def shape(self, el, index):
        kind = el.get("type")
        p = self.props(el, nested=("bsdf", "ref", "emitter"))
        m = p.get("to_world", np.eye(4))
        material, radiance, uvs = Material((0.5, 0.5, 0.5)), None, None
        for c in el:
            if c.tag in ("bsdf", "ref"):
                material = self.bsdf(c)
            elif c.tag == "emitter":
                if c.get("type") != "area":
                    self.fail(c, "only area emitters are read on shapes")
                radiance = self.props(c).get("radiance", (1.0, 1.0, 1.0))
        if kind == "rectangle":
            pos = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
            faces = np.array([[0, 1, 2], [0, 2, 3]])
            normals = None
        elif kind == "cube":
            pos, faces = _cube()
            normals = None
        elif kind == "sphere":
            pos, faces = _sphere(64, 32)
            normals = pos.copy()
            s = np.eye(4)
            s[:3, :3] *= p.get("radius", 1.0)
            s[:3, 3] = p.get("center", (0.0, 0.0, 0.0))
            m = m @ s
        elif kind in ("obj", "ply"):
            file = self.path.parent / self.attr(el.find("string[@name='filename']"), "value")
            if kind == "obj":
                pos, faces = _read_obj(file)
            else:
                pos, faces, uvs = _read_ply(file)
            normals = None
        else:
            self.fail(el, "shape type not read")
        world = (np.c_[pos, np.ones(len(pos))] @ m.T)[:, :3]
        if normals is not None:
            n = normals @ np.linalg.inv(m[:3, :3])
            normals = n / np.linalg.norm(n, axis=1, keepdims=True)
        name = el.get("id") or f"shape{index}"
        if radiance is not None:
            material = replace(material, radiance=radiance)
        if material.texture is not None and uvs is None:
            self.fail(el, "a textured shape without texture coordinates is not read")
        return Mesh(name, world, faces, normals, material, uvs)

    def read(self):
        root = ET.parse(self.path).getroot()
        for d in root.iter("default"):
            if d.get("name") not in self.overrides:
                self.defaults[d.get("name")] = d.get("value")
        camera, meshes, env, depth, sun = None, [], None, -1, None
        for i, el in enumerate(root):
            if el.tag == "bsdf":
                self.ids[el.get("id")] = self.bsdf(el)
            elif el.tag == "integrator":
                depth = int(self.props(el).get("max_depth", -1))
                if el.get("type") != "path":
                    self.fail(el, "only the path integrator is compared")
            elif el.tag == "sensor":
                camera = self.sensor(el)
            elif el.tag == "shape":
                meshes.append(self.shape(el, i))
            elif el.tag == "emitter" and el.get("type") == "directional" and sun is None:
                p = self.props(el)
                if "direction" not in p:
                    self.fail(el, "only a directional light given by `direction` is read")
                e = p.get("irradiance", (1.0, 1.0, 1.0))
                sun = (p["direction"], e if isinstance(e, tuple) else (e, e, e))
            elif el.tag == "emitter":
                if el.get("type") != "constant":
                    self.fail(el, "only constant environments and one directional light are read")
                env = self.props(el).get("radiance", (1.0, 1.0, 1.0))
            elif el.tag in ("default",):
                continue
            else:
                self.fail(el, "element not read")
        if camera is None:
            raise Unsupported(f"{self.path}: no <sensor>")
        return Scene(camera, meshes, env, depth, sun)

    def sensor(self, el):
        if el.get("type") != "perspective":
            self.fail(el, "only perspective sensors are read")
        p = self.props(el, nested=("film", "sampler"))
        film = self.props(el.find("film"), nested=("rfilter",))
        rfilter = el.find("film/rfilter")
        if rfilter is not None and rfilter.get("type") != "box":
            self.fail(rfilter, "only the box filter is compared")
        w, h = int(film.get("width", 768)), int(film.get("height", 576))
        m = p.get("to_world", np.eye(4))
        fov, axis = p.get("fov", 39.3077), p.get("fov_axis", "x")
        if axis == "smaller":
            axis = "x" if w <= h else "y"
        elif axis == "larger":
            axis = "x" if w >= h else "y"
        if axis == "y":
            fov = math.degrees(2 * math.atan(math.tan(math.radians(fov) / 2) * w / h))
        origin = m[:3, 3]
        return Camera(tuple(origin), tuple(origin + m[:3, 2]), tuple(m[:3, 1]), fov, w, h)


def _cube():
    pos, faces = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, v = [(a) for a in range(3) if a != axis]
            corners = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = sign, a, b
                corners.append(p)
            base = len(pos)
            pos += corners
            # Outward winding: counter-clockwise seen from outside.
            n = np.zeros(3)
            n[axis] = sign
            e = np.cross(np.subtract(corners[1], corners[0]), np.subtract(corners[2], corners[0]))
            quad = [[0, 1, 2], [0, 2, 3]] if np.dot(e, n) > 0 else [[0, 2, 1], [0, 3, 2]]
            faces += [[base + i for i in t] for t in quad]
    return np.array(pos), np.array(faces)


def _sphere(nu, nv):
    pos = []
    for j in range(nv + 1):
        theta = math.pi * j / nv
        for i in range(nu + 1):
            phi = 2 * math.pi * i / nu
            pos.append([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                        math.cos(theta)])
    faces = []
    for j in range(nv):
        for i in range(nu):
            a, b = j * (nu + 1) + i, (j + 1) * (nu + 1) + i
            faces += [[a, b, a + 1], [a + 1, b, b + 1]]
    return np.array(pos), np.array(faces)


def _read_obj(path):
    pos, faces = [], []
    for line in open(path, encoding="utf-8", errors="replace"):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            pos.append([float(x) for x in t[1:4]])
        elif t[0] == "f":
            idx = [int(x.split("/")[0]) for x in t[1:]]
            idx = [i - 1 if i > 0 else len(pos) + i for i in idx]
            faces += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    return np.array(pos, float), np.array(faces)


_PLY_TYPES = {"float": "f4", "float32": "f4", "double": "f8", "uchar": "u1", "uint8": "u1",
              "char": "i1", "int8": "i1", "int": "i4", "int32": "i4", "uint": "u4",
              "uint32": "u4", "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2"}


def _ply_uvs(names, column):
    """The texture coordinates of a PLY's vertex properties `names` (None without them)."""
    for u, v in (("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")):
        if u in names and v in names:
            return np.stack([column(u), column(v)], axis=1).astype(float)
    return None


def _read_ply(path):
    """Positions (N, 3), triangles (M, 3) and texture coordinates (N, 2) or None."""
    data = open(path, "rb").read()
    end = data.index(b"end_header") + len(b"end_header")
    end += 2 if data[end:end + 2] == b"\r\n" else 1
    header = data[:end].decode("ascii").split("\n")
    fmt = next(line.split()[1] for line in header if line.startswith("format"))
    elements, cur = [], None
    for line in header:
        t = line.split()
        if t[:1] == ["element"]:
            cur = [t[1], int(t[2]), []]
            elements.append(cur)
        elif t[:1] == ["property"]:
            cur[2].append(t[1:])
    if fmt == "ascii":
        return _read_ply_ascii(data[end:], elements)
    order = "<" if fmt == "binary_little_endian" else ">"
    off, pos, faces, uvs = end, None, None, None
    for name, count, props in elements:
        if all(p[0] != "list" for p in props):
            dt = np.dtype([(p[-1], order + _PLY_TYPES[p[0]]) for p in props])
            rows = np.frombuffer(data, dt, count, off)
            off += dt.itemsize * count
            if name == "vertex":
                pos = np.stack([rows[c] for c in "xyz"], axis=1).astype(float)
                uvs = _ply_uvs(rows.dtype.names, lambda c: rows[c])
            continue
        if name != "face" or len(props) != 1:
            raise Unsupported(f"{path}: PLY element {name!r} with lists is not read")
        _, count_type, index_type, _ = props[0]
        # Read as triangles in one go; if any face is not one, fall back to face by face.
        dt = np.dtype([("n", order + _PLY_TYPES[count_type]),
                       ("i", order + _PLY_TYPES[index_type], 3)])
        rows = np.frombuffer(data, dt, count, off) if off + dt.itemsize * count <= len(data) \
            else None
        if rows is not None and np.all(rows["n"] == 3):
            faces = rows["i"].astype(np.int64)
            off += dt.itemsize * count
            continue
        ct, it = np.dtype(order + _PLY_TYPES[count_type]), np.dtype(order + _PLY_TYPES[index_type])
        tris = []
        for _ in range(count):
            n = int(np.frombuffer(data, ct, 1, off)[0])
            off += ct.itemsize
            idx = np.frombuffer(data, it, n, off)
            off += it.itemsize * n
            tris += [[idx[0], idx[i], idx[i + 1]] for i in range(1, n - 1)]
        faces = np.array(tris, np.int64)
    return pos, faces, uvs


def _read_ply_ascii(body, elements):
    tokens = body.split()
    k = 0
    pos, faces, cols = [], [], {}
    for name, count, props in elements:
        for _ in range(count):
            if name == "vertex":
                row = [float(tokens[k + i]) for i in range(len(props))]
                k += len(props)
                names = [p[-1] for p in props]
                pos.append([row[names.index(c)] for c in "xyz"])
                for n, v in zip(names, row):
                    cols.setdefault(n, []).append(v)
            elif name == "face":
                n = int(tokens[k])
                idx = [int(tokens[k + 1 + i]) for i in range(n)]
                k += 1 + n
                faces += [[idx[0], idx[i], idx[i + 1]] for i in range(1, n - 1)]
    return np.array(pos, float), np.array(faces), _ply_uvs(cols, lambda c: np.array(cols[c]))


def read_scene(path, **overrides):
    """The scene of a Mitsuba 3 XML file (`overrides`: values for its `<default>`s)."""
    return _Reader(path, {k: str(v) for k, v in overrides.items()}).read()
