"""The sensor chain in one pass: the same bytes as its stages one by one, compiled or in numpy."""

import hashlib
import os
import subprocess
import sys

import numpy as np
import pytest

from rollsim.render import RenderPipeline
from rollsim.scene import load_scene
import rollsim.sensor.chain as chain
from rollsim.sensor.chain import BLOCK_PIXELS, Adc, ChainKeys, _chain_numpy, run_chain
from rollsim.sensor.poisson import PoissonTables
from rollsim.sensor.adc import gray8_lut

SMALL = ["camera.width_px=320", "camera.height_px=240"]

# Scenes whose noise chain fuses whole, in part (an offset between the clip and
# the read noise, blooming between the shot noise and the clip), or not at all.
SCENES = [
    ("paper-geometric", []),
    ("paper-default", []),
    ("paper-geometric", ["effects.shot_noise.method=gaussian"]),
    ("paper-geometric", ["camera.output=raw16"]),
    ("effect-vignetting", []),
    ("effect-row_noise", []),
    ("effect-blooming", []),
    ("effect-bayer", []),
    ("effect-isp", []),
    ("stress-high-iso", []),
    ("stress-saturation", []),
    ("paper-geometric", ["effects=[read_noise]"]),
    ("paper-geometric", ["effects.read_noise.method=exact"]),
    # Without noise: the clip, the ADC and the output table in one compiled pass.
    ("paper-geometric", ["effects=[]"]),
    ("paper-geometric", ["effects=[]", "camera.output=raw16"]),
    ("stress-saturation", ["effects.shot_noise=null", "effects.read_noise=null"]),
    ("effect-blooming", ["effects.shot_noise=null", "effects.read_noise=null"]),
    ("effect-bayer", ["effects.shot_noise=null", "effects.read_noise=null"]),
]


@pytest.mark.parametrize("name, overrides", SCENES, ids=lambda v: v if isinstance(v, str) else ",".join(v) or "-")
def test_fused_chain_renders_the_bytes_of_its_stages(name, overrides):
    scene = load_scene(name, SMALL + overrides)
    fused, staged = RenderPipeline(scene), RenderPipeline(scene, fuse=False)
    assert fused.stage_names == staged.stage_names
    for index in (0, 3):
        a, b = fused.render(index), staged.render(index)
        assert a.image.dtype == b.image.dtype and np.array_equal(a.image, b.image)
        assert a.truth == b.truth


def test_the_default_chain_is_one_stage():
    pipeline = RenderPipeline(load_scene("paper-geometric", SMALL))
    names = [stage.name for stage in pipeline.stages]
    assert "shot_noise[poisson]+full_well+read_noise[table]+adc+gray8" in names
    assert "shot_noise[poisson]" in pipeline.stage_names and len(names) < len(pipeline.stage_names)


def test_an_offset_between_clip_and_read_noise_splits_the_chain():
    pipeline = RenderPipeline(load_scene("paper-geometric", SMALL + ["effects.dsnu={}"]))
    names = [stage.name for stage in pipeline.stages]
    assert "shot_noise[poisson]+full_well" in names and "read_noise[table]+adc+gray8" in names


def _frame_digest(extra_env: dict) -> str:
    code = (
        "import hashlib; from rollsim.render import RenderPipeline; from rollsim.scene import load_scene;"
        f"p = RenderPipeline(load_scene('paper-default', {SMALL!r}));"
        "print(hashlib.sha256(b''.join(p.render(i).image.tobytes() for i in range(3))).hexdigest())"
    )
    env = {**os.environ, **extra_env}
    return subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True).stdout.strip()


def test_numpy_twin_renders_the_bytes_of_the_compiled_kernel():
    """ROLLSIM_JIT=0 (no numba) renders byte-identical frames."""
    pipeline = RenderPipeline(load_scene("paper-default", SMALL))
    here = hashlib.sha256(b"".join(pipeline.render(i).image.tobytes() for i in range(3))).hexdigest()
    assert _frame_digest({"ROLLSIM_JIT": "0"}) == here


@pytest.mark.parametrize("shot", ["poisson", "gaussian", None])
def test_every_part_of_the_chain_equals_the_numpy_twin(shot):
    rng = np.random.default_rng(2)
    lam = np.concatenate([np.full(2000, 10.27), rng.uniform(0, 60, 2000), rng.uniform(300, 6e4, 200), [0.0, 0.2]])
    keys = ChainKeys(np.uint64(5), np.uint64(6))
    adc, lut = Adc(22.0, 64, 10), gray8_lut(64, 10)
    for kwargs in ({}, {"full_well_e": 4500.0}, {"full_well_e": 44.0, "read_sigma_e": 2.0},
                   {"read_sigma_e": 2.0, "adc": adc}, {"full_well_e": 4500.0, "read_sigma_e": 2.0, "adc": adc, "lut": lut}):
        numpy_twin = _chain_numpy(lam, shot, keys, kwargs.get("full_well_e"), kwargs.get("read_sigma_e"),
                                  kwargs.get("adc"), kwargs.get("lut"))
        assert np.array_equal(run_chain(lam, shot, keys, **kwargs), numpy_twin), kwargs


def test_blocks_and_tables_built_mid_frame_keep_the_numpy_twins_bytes(monkeypatch):
    """Several blocks of the compiled chain, with an empty table store.

    The first block starts with means below 1 (no table), so the kernel
    stops in the middle of it at the first unbuilt class; every class from
    there on is built and the block runs again from its start. The bytes
    must still be the twin's.
    """
    monkeypatch.setattr(chain, "TABLES", PoissonTables())
    rng = np.random.default_rng(7)
    n = BLOCK_PIXELS
    lam = np.concatenate([np.full(n // 2, 0.3), np.full(n, 10.27), np.full(n, 0.3), rng.uniform(1.0, 256.0, n),
                          rng.uniform(256.0, 6e4, n), rng.permutation(np.r_[np.full(n // 2, 4.0), rng.uniform(0, 3, n // 2)]),
                          [0.0, 2.0**21, 99.5]])
    keys = ChainKeys(np.uint64(11), np.uint64(12))
    adc, lut = Adc(0.7, 64, 10), gray8_lut(64, 10)
    compiled = run_chain(lam, "poisson", keys, full_well_e=5e4, read_sigma_e=2.0, adc=adc, lut=lut)
    assert chain.TABLES.guide.size > 0
    assert np.array_equal(compiled, _chain_numpy(lam, "poisson", keys, 5e4, 2.0, adc, lut))


@pytest.mark.parametrize("shot", ["poisson", "gaussian"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_path_of_the_compiled_shot_noise_is_the_twins(shot, seed, monkeypatch):
    """Means that take every way through the kernel, shuffled across block boundaries, and
    the numpy twin in parts of 1,000 pixels (each pixel's words from its index in the frame).

    Means below 1 (a remainder drawn alone), class means exactly (no
    remainder), means in [1, 256) (guide bins with and without a CDF step,
    remainders that draw 0 or more), 256 and above (several classes), beyond
    the tables (the normal approximation), and runs of one mean.
    """
    rng = np.random.default_rng(seed)
    n = 3 * BLOCK_PIXELS + 17
    parts = [rng.uniform(0.0, 1.0, n // 8), np.full(n // 8, 4.0), rng.uniform(1.0, 256.0, n // 4),
             np.full(n // 8, 31.99), rng.uniform(256.0, 1e5, n // 8), np.full(n // 16, 2.0**21), np.zeros(n // 16)]
    lam = rng.permutation(np.concatenate(parts + [rng.uniform(0.0, 60.0, n - sum(p.size for p in parts))]))
    keys = ChainKeys(np.uint64(seed * 1000 + 1), np.uint64(seed * 1000 + 2))
    adc, lut = Adc(0.3, 64, 12), gray8_lut(64, 12)
    monkeypatch.setattr(chain, "NUMPY_PART_PIXELS", 1000)
    for kwargs in ({}, {"full_well_e": 2e5, "read_sigma_e": 3.0, "adc": adc, "lut": lut}, {"read_sigma_e": 0.5, "adc": adc}):
        numpy_twin = _chain_numpy(lam, shot, keys, kwargs.get("full_well_e"), kwargs.get("read_sigma_e"),
                                  kwargs.get("adc"), kwargs.get("lut"))
        assert np.array_equal(run_chain(lam, shot, keys, **kwargs), numpy_twin), kwargs


@pytest.mark.parametrize("shot", ["poisson", "gaussian"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -1e-300, -3.0])
def test_a_mean_that_is_not_a_finite_non_negative_number_is_refused(shot, bad):
    lam = np.full(2 * BLOCK_PIXELS, 5.0)
    lam[BLOCK_PIXELS + 7] = bad
    with pytest.raises(ValueError, match="finite and non-negative"):
        run_chain(lam, shot, ChainKeys(np.uint64(1), np.uint64(2)))


def test_photon_transfer_slope_is_the_gain():
    """Flat fields through the whole chain: variance against mean has slope K (EMVA 1288)."""
    gain = 0.5
    adc = Adc(gain, 64, 12)
    means, variances = [], []
    for level in (50.0, 200.0, 800.0, 2000.0):
        dn = run_chain(np.full((400, 400), level), "poisson", ChainKeys(np.uint64(level), np.uint64(9)),
                       full_well_e=1e5, read_sigma_e=3.0, adc=adc).astype(np.float64)
        means.append(dn.mean())
        variances.append(dn.var())
    slope = np.polyfit(means, variances, 1)[0]
    assert slope == pytest.approx(gain, rel=0.03)


def test_bad_arguments_name_what_is_wrong():
    lam = np.ones((2, 2))
    with pytest.raises(ValueError, match="shot must be"):
        run_chain(lam, "uniform", ChainKeys(np.uint64(1)))
    with pytest.raises(ValueError, match="needs its key"):
        run_chain(lam, "poisson", ChainKeys())
    with pytest.raises(ValueError, match="output table needs the ADC"):
        run_chain(lam, "poisson", ChainKeys(np.uint64(1)), lut=np.zeros(1024, np.uint8))
    with pytest.raises(ValueError, match="read noise"):
        run_chain(lam, "poisson", ChainKeys(np.uint64(1)), read_sigma_e=1.0)


def test_numpy_only_runs_the_twins_inside_the_block_and_nests():
    from rollsim.numerics import jit
    from rollsim.sensor.chain import _chain_kernel

    if _chain_kernel.compiled is None:
        pytest.skip("numba is not used here")
    with jit.numpy_only():
        assert _chain_kernel.compiled is None
        with jit.numpy_only(False):  # an inner block cannot switch it back on
            assert _chain_kernel.compiled is None
    assert _chain_kernel.compiled is not None


def test_short_renders_take_the_numpy_twins():
    from rollsim.render.writer import SHORT_RENDER_PIXELS, is_short_render

    scene = load_scene("paper-geometric")
    pixels = scene.camera.width_px * scene.camera.height_px
    assert is_short_render(scene, 1) and is_short_render(scene, SHORT_RENDER_PIXELS // pixels - 1)
    assert not is_short_render(scene, SHORT_RENDER_PIXELS // pixels + 1)


def test_kernel_cache_dir_is_keyed_by_the_kernel_sources(tmp_path, monkeypatch):
    from rollsim.numerics import jit

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    path = jit.kernel_cache_dir()
    assert path.parent == tmp_path and path.name == f"rollsim-{jit.sources_hash()}" and path.is_dir()


@pytest.mark.skipif(chain._noiseless_kernel.compiled is None, reason="numba is not installed or ROLLSIM_JIT=0")
@pytest.mark.parametrize("full_well", [None, 5000.0])
@pytest.mark.parametrize("table", [False, True])
def test_the_noiseless_chain_is_the_clip_and_the_adc_to_the_bit(full_well, table):
    from rollsim.sensor.adc import electrons_to_dn

    rng = np.random.default_rng(4)
    adc = Adc(0.37, 64, 10)
    # Means across the range, over the full well and the ADC's top, and on
    # the ADC's rounding edges (K·e + black + 0.5 a whole number).
    edges = (np.arange(1, 1000) - 0.5) / adc.gain_dn_per_e
    electrons = np.concatenate([rng.uniform(0, 8000, 20_000), edges, [0.0, 1e-300, 5000.0, 7e4, 1e9]]).reshape(4, -1)
    lut = gray8_lut(adc.black_level_dn, adc.bits, None) if table else None
    clipped = electrons if full_well is None else np.clip(electrons, 0.0, full_well)
    expected = electrons_to_dn(clipped.copy(), adc.gain_dn_per_e, adc.black_level_dn, adc.bits)
    if table:
        expected = lut[expected]
    dn = electrons_to_dn(clipped.copy(), adc.gain_dn_per_e, adc.black_level_dn, adc.bits)
    done = chain.run_noiseless_chain(electrons, full_well, adc, lut)
    # The stages' leavings: the clipped electrons (in place), the DN and the table's output.
    assert np.shares_memory(done.electrons, electrons)
    assert np.array_equal(done.electrons, clipped) and np.array_equal(done.dn, dn) and done.dn.dtype == np.uint16
    got = done.dn if lut is None else done.image
    assert got.dtype == expected.dtype and got.shape == electrons.shape
    assert np.array_equal(got, expected)


def test_the_warm_up_before_the_workers_fork_loads_what_the_frames_run():
    """numba keeps one machine code per pattern of arguments: the warm-up runs the scene's own
    stages, so a frame rendered after it (in a forked worker) loads no other."""
    from rollsim.render.writer import warm_up_render

    if chain._chain_kernel.compiled is None:
        pytest.skip("numba is not used here")
    pipeline = RenderPipeline(load_scene("paper-default", ["camera.width_px=320", "camera.height_px=240"]))
    warm_up_render(pipeline)
    loaded = len(chain._chain_kernel.compiled.signatures)
    pipeline.render(7)
    assert len(chain._chain_kernel.compiled.signatures) == loaded >= 1
