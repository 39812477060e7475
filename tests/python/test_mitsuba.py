"""The Mitsuba 3 sampler plugin "dpc" (dpc.mitsuba): it builds, registers, renders from a scene
dict and from XML like Mitsuba's own samplers, gives the values of dpc.Sampler, is unbiased and
fast, and says clearly what it cannot do."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest

import dpc

# Mitsuba-optional (with test_rendering_anchors.py): mitsuba (the mitsuba extra) is needed by
# nothing else, so without it this file skips (run_all.sh installs it, so CI runs it).
mi = pytest.importorskip("mitsuba", reason="mitsuba is not installed (pip install .[mitsuba])")
mi.set_variant("scalar_rgb")
import dpc.mitsuba  # noqa: E402  (builds the plugin once and registers it)


def _scene(sampler: dict, spp: int, width: int = 32, integrator=None) -> object:
    d = mi.cornell_box()
    d["sensor"]["sampler"] = dict(sampler, sample_count=spp)
    d["sensor"]["film"].update(width=width, height=width, rfilter={"type": "box"})
    d["integrator"] = integrator or {"type": "direct"}
    return mi.load_dict(d)


def test_renders_from_a_scene_dict_unbiased():
    """Over 64 seeds of 4-spp dpc renders, every pixel's mean is within 4 standard errors of a
    16,384-spp independent render, and so is the image mean."""
    ref = np.array(mi.render(_scene({"type": "independent"}, 16384))).mean(-1)
    imgs = np.stack([np.array(mi.render(_scene({"type": "dpc", "seed": s}, 4))).mean(-1) for s in range(64)])
    assert np.all(np.isfinite(imgs))
    se = imgs.std(0, ddof=1) / 8 + 1e-3  # + the reference's own error, at most ~1e-3 here
    assert np.abs((imgs.mean(0) - ref) / se).max() < 4
    totals = imgs.mean(axis=(1, 2))
    assert abs(totals.mean() - ref.mean()) < 4 * (totals.std(ddof=1) / 8 + 1e-4)


def test_loads_from_xml_with_every_property():
    xml = """<scene version="3.0.0">
      <integrator type="direct"/>
      <sensor type="perspective">
        <sampler type="dpc">
          <integer name="sample_count" value="8"/>
          <integer name="seed" value="3"/>
          <string name="model" value="bnot-2d-stratified,bnot-4d"/>
          <integer name="dimensions" value="6"/>
          <integer name="block_size" value="32"/>
          <integer name="fold_from" value="-1"/>
          <integer name="net_dims" value="2"/>
          <string name="net_layout" value="pixel"/>
        </sampler>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
      </sensor>
      <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    </scene>"""
    scene = mi.load_string(xml)
    sampler = scene.sensors()[0].sampler()
    assert sampler.sample_count() == 8
    assert "bnot-2d-stratified,bnot-4d" in str(sampler) and "fold_from = none" in str(sampler)
    assert "net_dims = 2" in str(sampler) and "net_layout = pixel" in str(sampler)
    assert "net_dims = default" in str(mi.load_dict({"type": "dpc"}))  # 2, or libdpc's for progressive models
    assert "net_dims = auto" in str(mi.load_dict({"type": "dpc", "net_dims": -1}))
    assert "net_layout = auto" in str(mi.load_dict({"type": "dpc"}))
    img = np.array(mi.render(scene))
    assert img.shape == (16, 16, 3) and np.all(np.isfinite(img))


def test_values_are_those_of_dpc_sampler():
    """The plugin asks libdpc for (pixel, sample index, dimension), the pixel being its place in
    its 32x32 block moved to the block's own tile: a fork seeded like Mitsuba's renderer seeds
    pixel (x, y) of the block whose first seed is b gives dpc.Sampler's values at
    (32 (b & 0xFFFF) + x, 32 (b >> 16) + y), and in a later block (b + 1024) the same place
    gives other values."""
    plugin = mi.load_dict({"type": "dpc", "sample_count": 4, "seed": 9, "dimensions": 3})
    # neither folds; the plugin's net_dims when not given is 2
    ref = dpc.Sampler("bnot-2d-stratified", samples_per_pixel=4, dimensions=3, seed=9, net_dims=2)
    fork = plugin.fork()
    # a fork's first seed starts a block, whatever the render seed; the second block has
    # nonzero high bits, so both halves of the block's name are used
    for block_base in (5 * 1024 + 77, 3 * 65536 + 5 * 1024 + 77 + 1024):
        fork.seed(block_base)
        bx, by = 32 * (block_base & 0xFFFF), 32 * (block_base >> 16)
        for morton, (x, y) in [(0, (0, 0)), (1, (1, 0)), (2, (0, 1)), (11, (1, 3)), (1023, (31, 31))]:
            fork.seed(block_base + morton)
            for i in range(5):  # index 4 is a second pass
                got = [fork.next_2d(), fork.next_1d(), fork.next_2d()]
                assert np.array_equal(np.array(got[0]), ref.get_2d(bx + x, by + y, i, 0))
                assert np.float32(got[1]) == ref.get_1d(bx + x, by + y, i, 1)
                assert np.array_equal(np.array(got[2]), ref.get_2d(bx + x, by + y, i, 2))
                fork.advance()


def test_frame_property_reads_that_frames_samples():
    """frames / frame: the render's sample i is libdpc's index frame * sample_count + i of a
    sampler with that many frames (dpc.Sampler's frame argument)."""
    ref = dpc.Sampler("bnot-2d-stratified", samples_per_pixel=2, dimensions=2, seed=3, frames=8)
    for frame in (0, 5, 9):  # 9: past the frames, a new pass
        fork = mi.load_dict({"type": "dpc", "sample_count": 2, "seed": 3, "dimensions": 2, "frames": 8, "frame": frame})
        fork = fork.fork()
        fork.seed(0)
        for i in range(2):
            assert np.array_equal(np.array(fork.next_2d()), ref.get_2d(0, 0, i, 0, frame=frame))
            assert np.float32(fork.next_1d()) == ref.get_1d(0, 0, i, 1, frame=frame)
            fork.advance()


def test_spectral_variants_put_the_nets_through_the_light_sample():
    """Spectral variants draw the wavelength's 1-D sample between the film position and the light
    sample: the plugin's default nets then serve dimensions 0-2 (net_dims 3), RGB ones 0-1."""
    rgb_default = dpc.Sampler("bnot-2d-stratified", samples_per_pixel=4, dimensions=4, seed=9, net_dims=2)
    ref = dpc.Sampler("bnot-2d-stratified", samples_per_pixel=4, dimensions=4, seed=9, net_dims=3)
    assert not np.array_equal(ref.get_2d(0, 0, np.arange(4), 2), rgb_default.get_2d(0, 0, np.arange(4), 2))
    mi.set_variant("scalar_spectral")
    try:
        fork = mi.load_dict({"type": "dpc", "sample_count": 4, "seed": 9, "dimensions": 4}).fork()
        fork.seed(0)  # block 0, pixel (0, 0)
        for i in range(4):
            assert np.array_equal(np.array(fork.next_2d()), ref.get_2d(0, 0, i, 0))
            assert np.float32(fork.next_1d()) == ref.get_1d(0, 0, i, 1)
            assert np.array_equal(np.array(fork.next_2d()), ref.get_2d(0, 0, i, 2))
            assert np.array_equal(np.array(fork.next_2d()), ref.get_2d(0, 0, i, 3))
            fork.advance()
    finally:
        mi.set_variant("scalar_rgb")


def _plane_under_sky(sampler: dict, width: int = 64) -> object:
    """A diffuse plane filling the view under a sky with one bright quarter, at infinity: every
    pixel integrates the same function of its light sample."""
    T = mi.ScalarTransform4f
    sky = np.full((16, 32, 3), 0.2, dtype=np.float32)
    sky[:8, :16] = 4.0
    return mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
            "sensor": {
                "type": "perspective",
                "fov": 30,
                "sampler": sampler,
                "to_world": T().look_at(origin=[0, 0, 1], target=[0, 0, 0], up=[0, 1, 0]),
                "film": {"type": "hdrfilm", "width": width, "height": width, "rfilter": {"type": "box"}},
            },
            "plane": {
                "type": "rectangle",
                "to_world": T().scale([10, 10, 1]),
                "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}},
            },
            "sky": {"type": "envmap", "bitmap": mi.Bitmap(sky)},
        }
    )


def test_blocks_and_render_seeds_draw_their_own_values():
    """Every 32x32 block of a render, and every mi.render seed, draws its own samples. On a scene
    where every pixel integrates the same function, blocks that shared their samples would share
    their error image (correlation 1); here the blocks' errors are uncorrelated, renders with
    seeds 0 and 1 differ (as the built-in samplers' do), and the same seed renders the same
    image."""
    scene = _plane_under_sky({"type": "dpc", "sample_count": 4})
    a, b, a2 = (np.array(mi.render(scene, seed=s)).mean(-1) for s in (0, 1, 0))
    assert a.std() > 0.01 * a.mean()  # the scene is what the docstring says: the samples matter
    assert np.array_equal(a, a2)
    assert not np.array_equal(a, b)
    err = a - a.mean()
    blocks = [err[y : y + 32, x : x + 32].ravel() for y in (0, 32) for x in (0, 32)]
    corr = [np.corrcoef(blocks[0], blk)[0, 1] for blk in blocks[1:]]
    assert max(abs(c) for c in corr) < 0.3, corr


def test_progressive_models_render_their_prefixes():
    """A progressive model (docs/progressive.md) in the plugin: a pixel's samples follow its
    table in order, so its first 16 are the table of 16 shifted (the same values as dpc.Sampler),
    and a render with it is finite; mixing it with a set model is refused with the reason."""
    plugin = mi.load_dict({"type": "dpc", "sample_count": 64, "seed": 2, "model": "progressive-2d", "dimensions": 2})
    ref = dpc.Sampler("progressive-2d", samples_per_pixel=64, dimensions=2, seed=2)
    fork = plugin.fork()
    fork.seed(40)  # pixel (0, 0) of the block named 40: dpc.Sampler's pixel (32 * 40, 0)
    for i in range(16):
        assert np.array_equal(np.array(fork.next_2d()), ref.get_2d(32 * 40, 0, i, 0))
        fork.advance()
    img = np.array(mi.render(_scene({"type": "dpc", "model": "progressive-2d"}, 16, width=16)))
    assert np.all(np.isfinite(img)) and img.mean() > 0
    with pytest.raises(Exception, match="progressive"):
        mi.load_dict({"type": "dpc", "model": "progressive-2d,bnot-2d-stratified"})


def test_bad_properties_say_what_is_wrong():
    for props, says in [
        ({"model": "no-such-model"}, "no-such-model"),
        ({"dimensions": 0}, "dimensions"),
        ({"block_size": 48}, "block_size"),
        ({"fold_from": -2}, "fold_from"),
        ({"net_dims": -2}, "net_dims"),
        ({"net_layout": "diagonal"}, "net_layout"),
        ({"sample_count": 0}, "samples_per_pixel"),
        ({"frames": 0}, "frames"),
        ({"frame": -1}, "frame"),
        ({"frames": 4, "net_dims": 2}, "net_dims"),
    ]:
        with pytest.raises(Exception, match=says):
            mi.load_dict({"type": "dpc", **props})


def test_render_time_is_close_to_independent():
    """Not a benchmark (bench/bench_rendering.py is): a loose check that a lookup costs
    nanoseconds, not a Python call: within 3x of independent on one 64x64, 64-spp render."""
    times = {}
    for name in ("independent", "dpc"):
        scene = _scene({"type": name}, 64, width=64)
        mi.render(scene)
        t = time.perf_counter()
        mi.render(scene)
        times[name] = time.perf_counter() - t
    assert times["dpc"] < 3 * times["independent"], times


def test_jit_variants_are_refused_with_the_reason():
    try:
        mi.set_variant("llvm_ad_rgb")
    except Exception as e:  # noqa: BLE001  (no LLVM on this machine: nothing to check)
        pytest.skip(f"llvm_ad_rgb unavailable here: {e}")
    try:
        with pytest.raises(Exception, match="scalar variants"):
            mi.load_dict({"type": "dpc"})
    finally:
        mi.set_variant("scalar_rgb")


_LOAD_IN_CHILD = """
import sys
import mitsuba as mi
mi.set_variant("scalar_rgb")
import dpc.mitsuba
s = mi.load_dict({"type": "dpc", "model": sys.argv[1], "sample_count": 4})
print("loaded", s)
"""


def test_a_fifo_named_like_a_model_on_dpc_model_path_is_skipped_not_opened(tmp_path):
    """The plugin finds names by libdpc's search (regular files only): a FIFO bnot-2d.onnx first
    on DPC_MODEL_PATH is passed over for the bundled bnot-2d, and a FIFO given as a path is
    refused at once. A hang fails the test by its timeout."""
    fifo = tmp_path / "bnot-2d.onnx"
    os.mkfifo(fifo)
    env = dict(os.environ, DPC_MODEL_PATH=str(tmp_path))
    for spec, ok in [("bnot-2d", True), (str(fifo), False)]:
        r = subprocess.run(
            [sys.executable, "-c", _LOAD_IN_CHILD, spec], env=env, capture_output=True, text=True, timeout=120
        )
        if ok:
            assert r.returncode == 0 and "loaded DpcSampler[model = bnot-2d" in r.stdout, r.stderr[-2000:]
        else:
            assert r.returncode != 0 and "a FIFO" in r.stderr, r.stderr[-2000:]


def test_a_nul_in_the_model_property_is_refused():
    with pytest.raises(Exception, match="NUL"):
        mi.load_dict({"type": "dpc", "model": "bnot-2d\x00whatever"})


def test_an_unknown_model_lists_the_bundled_ones_as_dpc_load_does():
    with pytest.raises(Exception) as e:
        mi.load_dict({"type": "dpc", "model": "no-such-model"})
    message = str(e.value)
    assert "no-such-model" in message and "models there: " in message  # libdpc's search lists them
    listed = message.split("models there: ", 1)[1]
    for name in dpc.available_models():
        assert name in listed
    with pytest.raises(dpc.ModelNotFoundError, match="bundled: " + dpc.available_models()[0]):
        dpc.load("no-such-model")
