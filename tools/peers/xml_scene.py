"""A small subset of Mitsuba 3's XML scene format, read into world-space triangle meshes, so
that renderers without a Mitsuba loader (Cycles through `bpy`, LuxCore through `pyluxcore`)
can be given the very scene file lumo and Mitsuba read.

What is read: `<default>` and `$name` substitution (overridable), `perspective` sensors
(`fov`, `fov_axis` x/y/smaller/larger, `to_world` as `lookat` or a transform), the film's
width and height, the integrator's `max_depth`; shapes `rectangle`, `cube`, `sphere` (center
and radius, or a unit sphere under `to_world`; tessellated), `obj` and `ply` files (triangles
and positions only, through a minimal reader: OBJ `v`/`f`, binary or ASCII PLY with float
vertices); `to_world` transforms built from `translate`, `scale`, `rotate`, `matrix`,
`lookat`, applied in order; BSDFs `diffuse` (rgb or a float reflectance), `twosided` around one
of them, `ref` by id; `area` emitters with rgb radiance; a `constant` environment. Anything
else raises `Unsupported` naming the element, so a comparison never runs on a scene that was
silently read as something else.
"""

import math
import re
import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


class Unsupported(Exception):
    """An element of the scene file that this reader does not translate."""


@dataclass
class Material:
    """What a peer needs to build the surface: a Lambertian reflectance, whether it reflects
    on both sides (Mitsuba's `twosided`; else its back is black), and the radiance it emits
    from its front side (None: not an emitter)."""

    reflectance: tuple
    radiance: tuple = None
    two_sided: bool = False


@dataclass
class Mesh:
    """World-space triangles: positions (N, 3), faces (M, 3) indices, per-vertex normals
    (N, 3) or None for flat shading."""

    name: str
    positions: np.ndarray
    faces: np.ndarray
    normals: object
    material: Material


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
    path length limit as Mitsuba counts it (max_depth, −1 = unlimited)."""

    camera: Camera
    meshes: list = field(default_factory=list)
    environment: object = None
    max_depth: int = -1


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
        """(reflectance, two-sided) of a BSDF element or reference."""
        if el.tag == "ref":
            return self.ids[el.get("id")]
        kind = el.get("type")
        if kind == "twosided":
            inner = [c for c in el if c.tag in ("bsdf", "ref")]
            if len(inner) != 1:
                self.fail(el, "twosided with two BSDFs is not read")
            return self.bsdf(inner[0])[0], True
        if kind != "diffuse":
            self.fail(el, "only diffuse BSDFs are read")
        r = self.props(el).get("reflectance", (0.5, 0.5, 0.5))
        return (r if isinstance(r, tuple) else (r, r, r)), False

    def shape(self, el, index):
        kind = el.get("type")
        p = self.props(el, nested=("bsdf", "ref", "emitter"))
        m = p.get("to_world", np.eye(4))
        (reflectance, two_sided), radiance = ((0.5, 0.5, 0.5), False), None
        for c in el:
            if c.tag in ("bsdf", "ref"):
                reflectance, two_sided = self.bsdf(c)
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
            pos, faces = _read_obj(file) if kind == "obj" else _read_ply(file)
            normals = None
        else:
            self.fail(el, "shape type not read")
        world = (np.c_[pos, np.ones(len(pos))] @ m.T)[:, :3]
        if normals is not None:
            n = normals @ np.linalg.inv(m[:3, :3])
            normals = n / np.linalg.norm(n, axis=1, keepdims=True)
        name = el.get("id") or f"shape{index}"
        return Mesh(name, world, faces, normals, Material(tuple(reflectance), radiance, two_sided))

    def read(self):
        root = ET.parse(self.path).getroot()
        for d in root.iter("default"):
            if d.get("name") not in self.overrides:
                self.defaults[d.get("name")] = d.get("value")
        camera, meshes, env, depth = None, [], None, -1
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
            elif el.tag == "emitter":
                if el.get("type") != "constant":
                    self.fail(el, "only constant environments are read")
                env = self.props(el).get("radiance", (1.0, 1.0, 1.0))
            elif el.tag in ("default",):
                continue
            else:
                self.fail(el, "element not read")
        if camera is None:
            raise Unsupported(f"{self.path}: no <sensor>")
        return Scene(camera, meshes, env, depth)

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


def _read_ply(path):
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
    sizes = {"float": "f", "float32": "f", "double": "d", "uchar": "B", "uint8": "B",
             "int": "i", "int32": "i", "uint": "I", "uint32": "I", "short": "h", "ushort": "H"}
    if fmt == "ascii":
        tokens = data[end:].split()
        k = 0
        pos, faces = [], []
        for name, count, props in elements:
            for _ in range(count):
                if name == "vertex":
                    row = [float(tokens[k + i]) for i in range(len(props))]
                    k += len(props)
                    names = [p[-1] for p in props]
                    pos.append([row[names.index(c)] for c in "xyz"])
                elif name == "face":
                    n = int(tokens[k])
                    idx = [int(tokens[k + 1 + i]) for i in range(n)]
                    k += 1 + n
                    faces += [[idx[0], idx[i], idx[i + 1]] for i in range(1, n - 1)]
        return np.array(pos, float), np.array(faces)
    order = "<" if fmt == "binary_little_endian" else ">"
    off, pos, faces = end, [], []
    for name, count, props in elements:
        for _ in range(count):
            row = {}
            for p in props:
                if p[0] == "list":
                    n = struct.unpack_from(order + sizes[p[1]], data, off)[0]
                    off += struct.calcsize(sizes[p[1]])
                    f = order + sizes[p[2]] * n
                    row[p[-1]] = struct.unpack_from(f, data, off)
                    off += struct.calcsize(f)
                else:
                    f = order + sizes[p[0]]
                    row[p[-1]] = struct.unpack_from(f, data, off)[0]
                    off += struct.calcsize(f)
            if name == "vertex":
                pos.append([row["x"], row["y"], row["z"]])
            elif name == "face":
                idx = row.get("vertex_indices") or row.get("vertex_index")
                faces += [[idx[0], idx[i], idx[i + 1]] for i in range(1, len(idx) - 1)]
    return np.array(pos, float), np.array(faces)


def read_scene(path, **overrides):
    """The scene of a Mitsuba 3 XML file (`overrides`: values for its `<default>`s)."""
    return _Reader(path, {k: str(v) for k, v in overrides.items()}).read()
