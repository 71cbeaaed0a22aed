"""The Python API against the CLI: same bytes for the same settings, passes that add up, and
bad input refused with lumo's messages."""

import json

import numpy as np
import pytest

import lumo
from lumo import LumoError

SIZE = (24, 16)


@pytest.fixture(scope="module")
def cornell():
    return lumo.load_scene("cornell")


def test_render_writes_the_bytes_of_lumo_render(cornell, lumo_cli, tmp_path):
    cli = tmp_path / "cli.exr"
    lumo_cli("render", "cornell", "--pipeline", "none", "--spp", "4", "--size", "24x16",
             "--seed", "3", "--aovs", tmp_path / "aovs", "-o", cli)
    r = cornell.render(spp=4, size=SIZE, seed=3)
    py = tmp_path / "py.exr"
    lumo.write_image(py, r.image())
    assert py.read_bytes() == cli.read_bytes()
    assert r.image().shape == (16, 24, 3) and r.image().dtype == np.float32
    for name, plane in r.aovs().items():
        want = lumo.read_image(tmp_path / "aovs" / f"{name}.exr")
        assert np.array_equal(plane, want, equal_nan=True), name


def test_passes_add_up_to_the_whole_render_bit_for_bit(cornell):
    whole = cornell.render(spp=7, size=SIZE)
    parts = cornell.render(passes=(3, 7), size=SIZE) + cornell.render(passes=(0, 1), size=SIZE)
    parts = parts + cornell.render(passes=(1, 3), size=SIZE)
    assert parts.spp == 7 and parts.passes == [(0, 1), (1, 3), (3, 7)]
    assert np.array_equal(parts.image(), whole.image())
    for name, plane in whole.aovs().items():
        assert np.array_equal(parts.aovs()[name], plane, equal_nan=True), name


def test_passes_that_overlap_or_differ_do_not_add(cornell):
    a = cornell.render(passes=(0, 4), size=SIZE)
    with pytest.raises(LumoError, match="overlap"):
        a + cornell.render(passes=(2, 6), size=SIZE)
    with pytest.raises(LumoError, match="differ"):
        a + cornell.render(passes=(4, 8), size=SIZE, seed=1)


def test_other_integrators_render_whole_images(cornell, lumo_cli, tmp_path):
    cli = tmp_path / "bdpt.exr"
    lumo_cli("render", "cornell", "--integrator", "bdpt", "--spp", "2", "--size", "24x16", "-o", cli)
    r = cornell.render(spp=2, size=SIZE, integrator="bdpt")
    assert np.array_equal(r.image(), lumo.read_image(cli))
    with pytest.raises(LumoError, match="whole images"):
        cornell.render(passes=(0, 2), integrator="bdpt")
    with pytest.raises(LumoError, match="aovs"):
        r.aovs()


def test_scene_errors_carry_lumos_messages(tmp_path):
    with pytest.raises(LumoError, match="does not exist"):
        lumo.load_scene(tmp_path / "missing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0"><shape type="obj"><string name="filename" value="nope.obj"/></shape></scene>')
    with pytest.raises(LumoError, match="nope.obj"):
        lumo.load_scene(bad)
    with pytest.raises(LumoError, match="size"):
        lumo.load_scene("cornell").render(size=(0, 4))
    with pytest.raises(LumoError, match="integrator"):
        lumo.load_scene("cornell").render(integrator="nope")


def test_denoise_equals_lumo_denoise(cornell, lumo_cli, tmp_path):
    aovs = tmp_path / "aovs"
    lumo_cli("render", "cornell", "--pipeline", "none", "--spp", "2", "--size", "32x32", "--aovs", aovs,
             "-o", tmp_path / "noisy.exr")
    for filt in ("auto", "atrous"):
        cli = tmp_path / f"cli-{filt}.exr"
        lumo_cli("denoise", "--input-dir", aovs, "--filter", filt, "-o", cli)
        planes = {n: lumo.read_image(aovs / f"{n}.exr")
                  for n in ("color", "albedo", "normal", "position", "depth", "variance", "emission")}
        out = lumo.denoise(planes.pop("color"), filter=filt, **planes)
        py = tmp_path / f"py-{filt}.exr"
        lumo.write_image(py, out)
        assert py.read_bytes() == cli.read_bytes(), filt


def test_denoise_refuses_bad_arrays():
    c = np.ones((8, 8, 3), np.float32)
    with pytest.raises(LumoError, match="not floating-point"):
        lumo.denoise(np.ones((8, 8, 3), np.int32))
    with pytest.raises(LumoError, match="shape"):
        lumo.denoise(np.ones((8, 8, 2), np.float32))
    with pytest.raises(LumoError):
        lumo.denoise(c, albedo=np.ones((4, 8, 3), np.float32))
    bad_variance = np.ones((8, 8), np.float32)
    bad_variance[2, 5] = np.nan
    with pytest.raises(LumoError, match=r"variance \(array\).*NaN"):
        lumo.denoise(c, variance=bad_variance, filter="atrous")
    with pytest.raises(LumoError, match="sigma"):
        lumo.denoise(c, filter="atrous", sigma_color=-1)


def test_compare_equals_lumo_compare(lumo_cli, tmp_path):
    rng = np.random.default_rng(1)
    ref = rng.random((16, 16, 3), dtype=np.float32)
    img = ref + rng.normal(0, 0.05, ref.shape).astype(np.float32)
    lumo.write_image(tmp_path / "ref.exr", ref)
    lumo.write_image(tmp_path / "img.exr", img)
    cli = json.loads(lumo_cli("compare", tmp_path / "ref.exr", tmp_path / "img.exr", "--json").stdout)
    got = lumo.compare(ref, img)
    row = cli["images"][0]
    for k, j in (("mse", "mse"), ("relmse", "relmse"), ("psnr", "psnr_db"), ("ssim", "ssim"), ("flip", "flip")):
        assert got[k] == pytest.approx(row[j], rel=1e-6, abs=1e-12), k
    same = lumo.compare(ref, ref)
    assert same["mse"] == 0 and same["psnr"] == float("inf")
    with pytest.raises(LumoError, match="size mismatch"):
        lumo.compare(ref, ref[:8])
    with pytest.raises(LumoError, match="exposure"):
        lumo.compare(ref, img, exposure=1e9)
    assert got["clipped_alike"] is False and "clipped_note" not in got


def test_compare_does_not_call_images_that_differ_only_where_they_clip_identical():
    ref = np.full((8, 8, 3), 5.0, dtype=np.float32)
    img = ref.copy()
    img[2:4, 2:4] = 9.0
    with pytest.warns(RuntimeWarning, match=r"--exposure -4"):
        m = lumo.compare(ref, img, exposure=6)
    assert m["clipped_alike"] is True and m["mse"] > 0
    assert m["psnr"] is None and m["ssim"] is None and m["flip"] is None
    # At the exposure the warning names, the difference shows.
    shown = lumo.compare(ref, img, exposure=-4)
    assert shown["clipped_alike"] is False and shown["flip"] > 0


def test_images_round_trip(tmp_path):
    a = np.linspace(0, 4, 5 * 7 * 3, dtype=np.float32).reshape(5, 7, 3)
    for ext in ("exr", "pfm"):
        lumo.write_image(tmp_path / f"a.{ext}", a)
        assert np.array_equal(lumo.read_image(tmp_path / f"a.{ext}"), a)
    d = np.arange(12, dtype=np.float32).reshape(3, 4)
    lumo.write_image(tmp_path / "d.exr", d)
    assert lumo.read_image(tmp_path / "d.exr").shape == (3, 4)
    with pytest.raises(LumoError, match="missing.exr"):
        lumo.read_image(tmp_path / "missing.exr")


def test_scene_defaults_come_from_the_scene_file(tmp_path):
    assert lumo.load_scene("cornell").default_spp == 16
    scene = tmp_path / "small.xml"
    scene.write_text(
        '<scene version="3.0.0"><integrator type="path"/>'
        '<sensor type="perspective"><sampler type="independent">'
        '<integer name="sample_count" value="3"/></sampler>'
        '<film type="hdrfilm"><integer name="width" value="20"/>'
        '<integer name="height" value="10"/></film></sensor>'
        '<shape type="sphere"><bsdf type="diffuse"/></shape>'
        '<emitter type="constant"/></scene>'
    )
    s = lumo.load_scene(scene)
    assert s.default_spp == 3 and s.default_size == (20, 10)
    assert s.render().image().shape == (10, 20, 3)
