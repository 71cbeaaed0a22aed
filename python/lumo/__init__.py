"""lumo: physically based global illumination with fast screen-space denoising.

Render a scene, denoise an image from any renderer, and score it, with numpy arrays in and
out::

    import lumo
    scene = lumo.load_scene("cornell")                 # a built-in scene, or a scene file
    r = scene.render(spp=16, size=(256, 256), seed=0)  # float32 (256, 256, 3) via r.image()
    planes = r.aovs()                                  # albedo, normal, depth, ...
    clean = lumo.denoise(r.image(), albedo=planes["albedo"], normal=planes["normal"],
                         depth=planes["depth"])
    print(lumo.compare(reference, clean))              # mse, relmse, psnr, ssim, flip, ...

Renders of sample ranges add up exactly: ``scene.render(passes=(0, 8)) +
scene.render(passes=(8, 16))`` is, bit for bit, ``scene.render(spp=16)``. ``lumo.ray``
spreads a ``lumo render`` command over a Ray cluster the same way. Errors are
:class:`LumoError` with lumo's own messages (the file, the field, the fix).
"""

from __future__ import annotations

import os
import tempfile
import warnings
from typing import Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import LumoError

__version__ = _native.version()

__all__ = [
    "LumoError",
    "Render",
    "Scene",
    "compare",
    "denoise",
    "load_scene",
    "read_image",
    "write_image",
]

#: Most samples per pixel of one render (``lumo render --spp``'s limit).
MAX_SPP = 1 << 20

_INTEGRATORS = ("path", "light", "bdpt", "ppm")


def _to_array(planar) -> np.ndarray:
    """``(bytes, height, width, channels)`` from the native module as a float32 array:
    ``(height, width)`` for one channel, else ``(height, width, channels)``."""
    data, h, w, c = planar
    a = np.frombuffer(data, dtype="<f4").reshape(h, w, c).astype(np.float32)
    return a[:, :, 0] if c == 1 else a


def _to_planar(image, name: str):
    """A numpy-like image as the native module's ``(bytes, height, width, channels)``, refusing
    what lumo cannot read: not floating-point, not 2-D or 3-D, not 1, 3 or 4 channels."""
    a = np.asarray(image)
    if a.dtype.kind != "f":
        raise LumoError(
            f"{name}: dtype {a.dtype} is not floating-point; pass linear float32 (or float16/64) "
            f"values, e.g. {name}.astype(np.float32) / 255 for 8-bit data"
        )
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[2] not in (1, 3, 4) or a.shape[0] == 0 or a.shape[1] == 0:
        raise LumoError(
            f"{name}: shape {np.shape(image)} is not an image; expected (height, width), "
            f"(height, width, 1), (height, width, 3) or (height, width, 4)"
        )
    a = np.ascontiguousarray(a, dtype="<f4")
    h, w, c = a.shape
    return (a.tobytes(), h, w, c)


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """Reads an OpenEXR (half or float), PFM or PNG file as linear float32."""
    return _to_array(_native.read_image(os.fspath(path)))


def write_image(path: Union[str, os.PathLike], image) -> None:
    """Writes ``image`` as ``.exr`` (float32), ``.pfm`` or ``.png`` (8-bit sRGB), by the file's
    extension; the file is replaced atomically."""
    _native.write_image(os.fspath(path), _to_planar(image, "image"))


def compare(
    reference, image, exposure: float = 0.0, ppd: Optional[float] = None
) -> Dict[str, Optional[float]]:
    """The metrics of ``lumo compare``: ``mse``, ``relmse``, ``smape``, ``psnr``, ``ssim``,
    ``flip`` and ``nonfinite_pixels`` (pixels left out for NaN or Inf), of ``image`` against
    ``reference``; ``exposure`` in stops applies before tone mapping, ``ppd`` is FLIP's pixels
    per degree (default 67).

    Where the images differ only in pixels that both clip at this exposure, ``clipped_alike``
    is True, ``psnr``, ``ssim`` and ``flip`` are None (they would call the images identical,
    as ``lumo compare --json`` says with null) and a ``RuntimeWarning`` names an exposure at
    which the difference shows."""
    m = _native.compare(
        _to_planar(reference, "reference"), _to_planar(image, "image"), float(exposure), ppd
    )
    note = m.pop("clipped_note")
    if note is not None:
        warnings.warn(note, RuntimeWarning, stacklevel=2)
    return m


def _option(name: str, value) -> List[str]:
    flag = "--" + name.replace("_", "-")
    if value is True:
        return [flag]
    if value is False or value is None:
        return []
    # One word, so that a negative number is not read as a flag.
    return [f"{flag}={value}"]


def denoise(
    color,
    albedo=None,
    normal=None,
    position=None,
    depth=None,
    emission=None,
    variance=None,
    filter: str = "auto",
    **params,
) -> np.ndarray:
    """Denoises ``color`` with lumo's filters (``auto``, ``atrous``, ``guided``,
    ``bilateral``), steered by the given AOV planes, exactly as ``lumo denoise`` does with
    the same planes and options: ``params`` are its options with ``_`` for ``-``
    (``denoise(c, filter="atrous", sigma_color=2.0)`` is ``--sigma-color 2.0``; ``True`` for a
    flag such as ``no_detect_emitters=True``). The planes get the command's checks (sizes,
    NaN/Inf, negative variance, encoded normals) and its messages."""
    planes = {
        "color": color,
        "albedo": albedo,
        "normal": normal,
        "position": position,
        "depth": depth,
        "emission": emission,
        "variance": variance,
    }
    with tempfile.TemporaryDirectory(prefix="lumo-denoise-") as tmp:
        words: List[str] = []
        for name, plane in planes.items():
            if plane is None:
                continue
            path = os.path.join(tmp, f"{name}.exr")
            _native.write_image(path, _to_planar(plane, name))
            words += [f"--{name}", path]
        out = os.path.join(tmp, "denoised.exr")
        words += ["--filter", str(filter), "-o", out]
        for k, v in params.items():
            words += _option(k, v)
        try:
            _native.denoise_words(words)
        except LumoError as e:
            # Name the argument, not the temporary file it went through.
            msg = str(e)
            for name in planes:
                msg = msg.replace(os.path.join(tmp, f"{name}.exr"), f"{name} (array)")
            raise LumoError(msg) from None
        return read_image(out)


class Render:
    """The result of :meth:`Scene.render`: the exact sums of some sample passes of a frame.

    ``image()`` and ``aovs()`` are the means over the samples summed. Renders of disjoint
    sample ranges of one scene and settings add up with ``+``, bit for bit equal to rendering
    the union at once (sums are kept as 128-bit fixed-point integers)."""

    def __init__(self, passes=None, image: Optional[np.ndarray] = None, spp: int = 0):
        self._passes = passes
        self._image = image
        self._spp_whole = spp

    @property
    def spp(self) -> int:
        """Samples per pixel summed."""
        return self._passes.count if self._passes is not None else self._spp_whole

    @property
    def passes(self) -> List[Tuple[int, int]]:
        """Sample ranges ``(start, end)`` summed (empty for an integrator that renders whole
        images only)."""
        return list(self._passes.ranges) if self._passes is not None else []

    @property
    def size(self) -> Tuple[int, int]:
        """``(width, height)``."""
        if self._passes is not None:
            return tuple(self._passes.size)
        h, w = self._image.shape[:2]
        return (w, h)

    def image(self) -> np.ndarray:
        """The rendered image, float32 ``(height, width, 3)``, linear RGB."""
        if self._passes is None:
            return self._image.copy()
        return _to_array(self._passes.planes()["color"])

    def aovs(self) -> Dict[str, np.ndarray]:
        """The AOV planes of ``lumo render --aovs``: ``albedo``, ``normal``, ``position``,
        ``depth``, ``direct``, ``indirect``, ``variance`` (of the pixel mean's luminance) and
        ``emission``. The G-buffer planes are the pixel-centre sample's (sample 0)."""
        if self._passes is None:
            raise LumoError(
                "aovs(): this integrator renders the image only; use integrator='path' for AOVs"
            )
        planes = self._passes.planes()
        return {k: _to_array(v) for k, v in planes.items() if k != "color"}

    def __add__(self, other: "Render") -> "Render":
        if not isinstance(other, Render):
            return NotImplemented
        if self._passes is None or other._passes is None:
            raise LumoError(
                "only path-traced renders add up (light, bdpt and ppm render whole images)"
            )
        return Render(self._passes.add(other._passes))

    def __repr__(self) -> str:
        w, h = self.size
        return f"<lumo.Render {w}x{h}, {self.spp} spp, passes {self.passes}>"


class Scene:
    """A scene loaded by :func:`load_scene`; render it with :meth:`render`."""

    def __init__(self, source: str, defines: Sequence[Tuple[str, str]]):
        self.source = source
        self.defines = list(defines)
        self._plans: Dict[Tuple[str, ...], object] = {}
        # Loading the scene file raises LumoError where it cannot be read and says what it asks
        # for; its BVH is built once, by the first render.
        spp, size = _native.planned_defaults(self._words(None, None, None, None, False))
        #: The scene's own samples per pixel (its file's, or 16 for the built-ins).
        self.default_spp: int = spp
        #: The scene's own image size ``(width, height)`` (its file's, or 512x512).
        self.default_size: Tuple[int, int] = tuple(size)

    def _words(self, spp, size, seed, max_depth, spectral, integrator="path") -> List[str]:
        words = [self.source]
        for k, v in self.defines:
            words += ["-D", f"{k}={v}"]
        words += ["--pipeline", "none"]
        if spp is not None:
            words += ["--spp", str(spp)]
        if integrator != "path":
            words += ["--integrator", integrator]
        if size is not None:
            w, h = size
            words += ["--size", f"{int(w)}x{int(h)}"]
        if seed is not None:
            words += ["--seed", str(int(seed))]
        if max_depth is not None:
            words += ["--max-depth", str(int(max_depth))]
        if spectral:
            words.append("--spectral")
        return words

    def _plan(self, words: List[str]):
        key = tuple(words)
        plan = self._plans.get(key)
        if plan is None:
            plan = _native.RenderPlan(words)
            self._plans = {key: plan}  # keep one: a plan holds the scene's BVH
        return plan

    def render(
        self,
        spp: Optional[int] = None,
        size: Optional[Tuple[int, int]] = None,
        seed: Optional[int] = None,
        integrator: str = "path",
        max_depth: Optional[int] = None,
        spectral: bool = False,
        passes: Optional[Tuple[int, int]] = None,
    ) -> Render:
        """Renders samples ``0..spp`` of every pixel (default: the scene's sample count), or
        the sample range ``passes=(start, end)``, unfiltered (denoise with :func:`denoise`).

        ``size`` is ``(width, height)``; ``seed`` fixes the random numbers (same image on any
        thread count); ``max_depth`` follows Mitsuba (1 = emitters only, 2 = direct light);
        ``integrator`` is ``path`` (default), ``light``, ``bdpt`` or ``ppm`` (these three
        render whole images: no ``passes``, no AOVs); ``spectral`` runs hero-wavelength
        spectral transport."""
        if integrator not in _INTEGRATORS:
            raise LumoError(f"integrator {integrator!r}: use one of {', '.join(_INTEGRATORS)}")
        if integrator != "path":
            if passes is not None:
                raise LumoError(
                    f"passes: integrator {integrator!r} renders whole images; use integrator='path'"
                )
            words = self._words(spp, size, seed, max_depth, spectral, integrator)
            return Render(image=_to_array(_native.render_image(words)), spp=spp or self.default_spp)
        if passes is None:
            start, end = 0, int(self.default_spp if spp is None else spp)
        else:
            start, end = (int(passes[0]), int(passes[1]))
            if spp is not None and end > spp:
                raise LumoError(f"passes {start}..{end} reach past spp={spp}")
        if not (0 <= start < end <= MAX_SPP):
            raise LumoError(
                f"passes {start}..{end}: expected 0 <= start < end <= {MAX_SPP} (sample indices)"
            )
        # Every sample range is rendered from one plan of the most samples a render may have:
        # a sample depends only on (pixel, index, seed), so any two ranges add up.
        plan = self._plan(self._words(MAX_SPP, size, seed, max_depth, spectral))
        return Render(plan.render_passes(0, start, end - start))

    def __repr__(self) -> str:
        return f"<lumo.Scene {self.source!r}>"


def load_scene(
    path_or_builtin: Union[str, os.PathLike],
    defines: Optional[Union[Mapping[str, object], Iterable[Tuple[str, object]]]] = None,
) -> Scene:
    """Loads a built-in scene by name (``cornell``, ``cornell-spheres``, ...) or a scene file
    (Mitsuba 3 ``.xml``, glTF ``.gltf``/``.glb``, ``.obj``, ``.ply``); ``defines`` sets Mitsuba
    ``$name`` parameters (``-D name=value``). Raises :class:`LumoError` naming the file and the
    field when the scene cannot be loaded."""
    source = os.fspath(path_or_builtin)
    pairs = defines.items() if isinstance(defines, Mapping) else (defines or [])
    return Scene(source, [(str(k), str(v)) for k, v in pairs])
