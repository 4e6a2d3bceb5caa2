"""The LED's radiance profile (led_profile) and the lens's veiling glare (glare) against known answers."""

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import quad

from rollsim.errors import SceneError
from rollsim.optics.emitter import profiled_light, radial_table_light
from rollsim.optics.footprint import Footprint, footprint
from rollsim.optics import glare
from rollsim.optics.glare import fft_convolve_full, glare_core_px, glared_light, moffat_kernel, moffat_mass_beyond
from rollsim.portable_math import power as portable_power
from rollsim.render import RenderPipeline
from rollsim.scene import load_scene

from conftest import make_scene

FRAME = (120, 140)


def moffat_density(r, core_px, exponent):
    """The unit-mass Moffat profile per unit area (its analytic form)."""
    return (exponent - 1) / (math.pi * core_px**2) * (1 + (r / core_px) ** 2) ** -exponent


# ------------------------------------------------------------- the glare kernel
@pytest.mark.parametrize(("core_px", "exponent"), [(5.0, 1.5), (20.0, 2.0), (3.0, 3.5)])
def test_moffat_mass_beyond_matches_the_integral(core_px, exponent):
    for radius in (0.0, 7.0, 60.0, 500.0):
        inside, _ = quad(lambda r: 2 * math.pi * r * moffat_density(r, core_px, exponent), 0, radius, limit=200)
        assert moffat_mass_beyond(radius, core_px, exponent) == pytest.approx(1 - inside, abs=1e-9)


@pytest.mark.parametrize(("core_px", "exponent"), [(8.0, 2.0), (15.0, 1.5), (30.0, 3.0)])
def test_moffat_kernel_has_the_analytic_peak_and_mass(core_px, exponent):
    kernel = moffat_kernel(core_px, exponent, 200, 260)
    assert kernel.shape == (401, 521)
    # Sampling a smooth profile wider than a pixel: the normalised peak is
    # the analytic density at r = 0 (to the error of the midpoint rule).
    assert kernel[200, 260] == pytest.approx(moffat_density(0.0, core_px, exponent), rel=2e-3)
    dy, dx = np.indices(kernel.shape)
    inside = (dy - 200) ** 2 + (dx - 260) ** 2 <= 200**2
    # float32 samples: the mass to float32 precision.
    assert kernel[inside].sum(dtype=np.float64) == pytest.approx(1 - moffat_mass_beyond(200, core_px, exponent), rel=1e-6)
    # The rectangle's corners hold a little more, never more than the whole halo.
    assert kernel[inside].sum(dtype=np.float64) < kernel.sum(dtype=np.float64) < 1.0
    np.testing.assert_array_equal(kernel, kernel[::-1, ::-1])  # symmetric


@pytest.mark.parametrize(("core_px", "exponent"), [(0.0, 2.0), (5.0, 1.0), (-1.0, 2.0)])
def test_moffat_kernel_refuses_bad_parameters(core_px, exponent):
    with pytest.raises(ValueError):
        moffat_kernel(core_px, exponent, 5, 5)


def test_glare_core_px_is_the_thin_lens_angle():
    # 2 degrees at f = 4 mm over 1.12 um pixels.
    assert glare_core_px(2.0, 4e-3, 1.12e-6) == pytest.approx(4e-3 * math.tan(math.radians(2.0)) / 1.12e-6)


def point_light(row=60, col=70, value=1.0):
    return Footprint(slice(row, row + 1), slice(col, col + 1), np.array([[value]]))


def test_glare_of_a_point_is_the_kernel():
    """The impulse response: (1 - eta) at the point, eta x the kernel around it."""
    eta, core, beta = 0.3, 6.0, 2.0
    out = glared_light(point_light(), FRAME, eta, core, beta).dense(FRAME)
    # The kernel reaches from the lit pixel to every pixel of the frame: 61 rows, 71 columns.
    kernel = moffat_kernel(core, beta, 61, 71)
    ry, rx = (kernel.shape[0] - 1) // 2, (kernel.shape[1] - 1) // 2
    expected = eta * kernel[ry - 60 : ry - 60 + FRAME[0], rx - 70 : rx - 70 + FRAME[1]]
    expected[60, 70] += 1 - eta
    # float32 FFT: errors of ~1e-7 of the largest value.
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-7 * expected.max())


def test_glare_conserves_light_but_for_what_leaves_the_frame():
    fp = footprint((70.0, 60.0), 20.0, "disk", FRAME)
    eta, core, beta = 0.2, 4.0, 2.5
    out = glared_light(fp, FRAME, eta, core, beta)
    total, lit = out.coverage.sum(), fp.coverage.sum()
    # Scattered light beyond the nearest frame edge (seen from the disk's rim) may leave; no more.
    nearest_edge = min(60 - 10, FRAME[0] - 60 - 10, 70 - 10, FRAME[1] - 70 - 10)
    assert lit * (1 - eta * moffat_mass_beyond(nearest_edge, core, beta)) <= total <= lit
    assert out.coverage.min() >= 0
    np.testing.assert_array_equal(glared_light(fp, FRAME, 0.0, core, beta).dense(FRAME), fp.dense(FRAME))


def test_glare_is_linear_in_the_light():
    a, b = point_light(30, 40), point_light(80, 100, 2.5)
    both = Footprint(slice(30, 81), slice(40, 101), np.zeros((51, 61)))
    both.coverage[0, 0], both.coverage[50, 60] = 1.0, 2.5
    sum_of = glared_light(a, FRAME, 0.1, 5.0, 2.0).dense(FRAME) + glared_light(b, FRAME, 0.1, 5.0, 2.0).dense(FRAME)
    np.testing.assert_allclose(glared_light(both, FRAME, 0.1, 5.0, 2.0).dense(FRAME), sum_of, rtol=1e-5, atol=1e-9)


def reference_convolution(a, b):
    """The full convolution as scipy.signal.fftconvolve takes it (scipy.fft's transforms and sizes), the
    spectra multiplied with each product and sum rounded apart (numpy's complex product may fuse them)."""
    from scipy import fft

    shape = [n1 + n2 - 1 for n1, n2 in zip(a.shape, b.shape)]
    axes = [axis for axis in range(a.ndim) if a.shape[axis] != 1 and b.shape[axis] != 1]
    if not axes:
        return a * b
    fast = [fft.next_fast_len(shape[axis], True) for axis in axes]
    x, y = fft.rfftn(a, fast, axes=axes), fft.rfftn(b, fast, axes=axes)
    real, imag = x.real * y.real - x.imag * y.imag, x.real * y.imag + x.imag * y.real
    product = np.empty(real.shape, dtype=x.dtype)
    product.real, product.imag = real, imag
    return fft.irfftn(product, fast, axes=axes)[tuple(slice(n) for n in shape)]


CONVOLUTION_SHAPES = [((13, 17), (31, 29)), ((1, 7), (5, 9)), ((7, 1), (5, 9)), ((1, 1), (3, 3)), ((4, 6), (1, 1)),
                      ((310, 310), (701, 1117))]


@pytest.mark.parametrize("shape_a, shape_b", CONVOLUTION_SHAPES)
@pytest.mark.parametrize("workers", [1, 2])
def test_fft_convolution_is_scipy_ffts_to_the_bit(shape_a, shape_b, workers):
    """The halo's convolution, without importing scipy.fft, gives the float32 bits of scipy.fft's transforms
    with the spectra's product rounded term by term (threads or not)."""
    rng = np.random.default_rng(sum(shape_a + shape_b))
    a, b = rng.random(shape_a, dtype=np.float32), rng.random(shape_b, dtype=np.float32)
    expected, got = reference_convolution(a, b), fft_convolve_full(a, b, workers=workers)
    assert (got.dtype, got.shape) == (expected.dtype, expected.shape)
    assert got.tobytes() == expected.tobytes()


@pytest.mark.parametrize("shape_a, shape_b", CONVOLUTION_SHAPES)
def test_fft_convolution_is_scipy_signals_to_float32_precision(shape_a, shape_b):
    from scipy.signal import fftconvolve

    rng = np.random.default_rng(sum(shape_a + shape_b))
    a, b = rng.random(shape_a, dtype=np.float32), rng.random(shape_b, dtype=np.float32)
    expected, got = fftconvolve(a, b, mode="full"), fft_convolve_full(a, b)
    assert got.dtype == expected.dtype
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-5 * float(np.abs(expected).max()))


def test_the_spectra_product_is_each_term_rounded_apart():
    # The complex product (a + ib)(c + id) in float32 with every product and
    # sum rounded on its own, against the same in float64 rounded at the
    # end: within the one or two roundings the terms allow.
    rng = np.random.default_rng(3)
    x = (rng.standard_normal(1000) + 1j * rng.standard_normal(1000)).astype(np.complex64)
    y = (rng.standard_normal(1000) + 1j * rng.standard_normal(1000)).astype(np.complex64)
    exact = x.astype(np.complex128) * y.astype(np.complex128)
    got = glare.spectrum_product(x.copy(), y)
    assert got.dtype == np.complex64
    np.testing.assert_allclose(got, exact, rtol=0, atol=4 * np.finfo(np.float32).eps * float(np.abs(exact).max()))
    re = x.real * y.real
    re -= x.imag * y.imag
    assert got.real.tobytes() == re.tobytes()


def direct_moffat_kernel(core_px, exponent, ry, rx):
    """The kernel as moffat_kernel computed it before its quadrant: every sample's power taken."""
    dy = np.arange(-ry, ry + 1, dtype=np.float32)[:, None] / np.float32(core_px)
    dx = np.arange(-rx, rx + 1, dtype=np.float32)[None, :] / np.float32(core_px)
    kernel = dy**2 + dx**2
    kernel += np.float32(1.0)
    kernel = portable_power(kernel, -exponent).astype(np.float32)
    offsets_y, offsets_x = np.indices(kernel.shape)
    inside = (offsets_y - ry) ** 2 + (offsets_x - rx) ** 2 <= min(ry, rx) ** 2
    kernel *= np.float32((1.0 - moffat_mass_beyond(min(ry, rx), core_px, exponent)) / kernel[inside].sum(dtype=np.float64))
    return kernel


@pytest.mark.parametrize(("core_px", "exponent", "ry", "rx"), [(8.0, 2.0, 200, 260), (15.0, 1.5, 3, 9), (3.0, 3.5, 50, 7),
                                                             (208.24, 2.0, 695, 1115), (0.5, 4.0, 0, 6)])
def test_moffat_kernel_mirrors_its_quadrant_to_the_bit(core_px, exponent, ry, rx):
    """Powers taken on one quadrant and mirrored: every sample the direct formula's, the scale too."""
    kernel = moffat_kernel(core_px, exponent, ry, rx)
    assert kernel.dtype == np.float32 and kernel.flags.c_contiguous
    assert kernel.tobytes() == direct_moffat_kernel(core_px, exponent, ry, rx).tobytes()


def test_the_transforms_are_scipy_ffts_extension_without_scipy_fft():
    """The halo's transforms come from scipy.fft's own compiled module, loaded
    on its own; without it (another SciPy layout) scipy.fft gives the same bits."""
    assert glare._pocketfft() is not None  # the fast path is the one these tests check
    rng = np.random.default_rng(5)
    a, b = rng.random((40, 31), dtype=np.float32), rng.random((77, 90), dtype=np.float32)
    direct = fft_convolve_full(a, b)
    try:
        glare._pocketfft.cache_clear()
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(glare, "_pocketfft", lambda: None)
            assert fft_convolve_full(a, b).tobytes() == direct.tobytes()
    finally:
        glare._pocketfft.cache_clear()


def reference_glare(light, frame, eta, core, beta):
    """glared_light as it was: the reference full convolution with the directly computed kernel, cut to the frame."""
    height, width = frame
    out = light.dense(frame) * (1.0 - eta)
    ry = max(light.rows.stop, height - light.rows.start)
    rx = max(light.cols.stop, width - light.cols.start)
    halo = reference_convolution(light.coverage.astype(np.float32), direct_moffat_kernel(core, beta, ry, rx))
    top, left = ry - light.rows.start, rx - light.cols.start
    out += eta * halo[top : top + height, left : left + width].astype(np.float64)
    return np.maximum(out, 0.0)


GLARE_CASES = [
    ((120, 140), (60, 61), (70, 71)),  # a point
    ((120, 140), (0, 1), (0, 1)),  # in a corner
    ((120, 140), (119, 120), (139, 140)),  # in the opposite corner
    ((120, 140), (30, 81), (40, 101)),  # a box
    ((120, 140), (0, 120), (0, 140)),  # the whole frame
    ((1, 9), (0, 1), (2, 5)),  # one row
    ((37, 53), (5, 36), (50, 53)),
]


@pytest.mark.parametrize(("frame", "rows", "cols"), GLARE_CASES)
@pytest.mark.parametrize(("eta", "core", "beta"), [(0.3, 6.0, 2.0), (1.0, 0.5, 4.0), (0.8, 208.0, 2.0)])
def test_glare_is_the_reference_convolution_to_the_bit(frame, rows, cols, eta, core, beta):
    """The frames carry the halo's float32 bits (another rounding moves a few
    pixels by a level): glared_light is the reference convolution's, exactly."""
    coverage = np.random.default_rng(sum(rows + cols)).random((rows[1] - rows[0], cols[1] - cols[0]))
    light = Footprint(slice(*rows), slice(*cols), coverage)
    got = glared_light(light, frame, eta, core, beta)
    assert got.coverage.tobytes() == reference_glare(light, frame, eta, core, beta).tobytes()


# ----------------------------------------------------------- the face's profile
def test_profile_conserves_light_and_follows_the_gaussian():
    fp = footprint((70.0, 60.0), 40.0, "disk", FRAME)
    sigma = 6.0
    light = profiled_light(fp, (70.0, 60.0), sigma)
    assert light.coverage.sum() == pytest.approx(fp.coverage.sum(), rel=1e-12)
    # Two fully covered pixels: their ratio is the Gaussian's.
    (r1, c1), (r2, c2) = (60, 70), (60, 80)  # pixel centres 0.5 and ~10.5 px from the centre
    i1, j1, i2, j2 = r1 - fp.rows.start, c1 - fp.cols.start, r2 - fp.rows.start, c2 - fp.cols.start
    rho1, rho2 = math.hypot(0.5, 0.5), math.hypot(10.5, 0.5)
    ratio = light.coverage[i2, j2] / light.coverage[i1, j1]
    assert ratio == pytest.approx(math.exp(-(rho2**2 - rho1**2) / (2 * sigma**2)), rel=1e-12)


def test_profile_far_wider_than_the_face_is_uniform():
    fp = footprint((70.0, 60.0), 20.0, "disk", FRAME)
    np.testing.assert_allclose(profiled_light(fp, (70.0, 60.0), 1e6).coverage, fp.coverage, rtol=1e-9)


def test_profile_far_narrower_than_a_pixel_stays_finite():
    fp = footprint((70.3, 60.2), 20.0, "disk", FRAME)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        light = profiled_light(fp, (70.3, 60.2), 1e-6)
    assert np.isfinite(light.coverage).all()
    assert light.coverage.sum() == pytest.approx(fp.coverage.sum(), rel=1e-12)
    assert light.coverage.max() == pytest.approx(fp.coverage.sum(), rel=1e-12)  # all of it in one pixel


def test_profile_refuses_a_bad_sigma():
    with pytest.raises(ValueError, match="sigma_px"):
        profiled_light(footprint((70.0, 60.0), 20.0, "disk", FRAME), (70.0, 60.0), 0.0)


def test_a_measured_radial_table_conserves_light_and_follows_the_table():
    fp = footprint((70.0, 60.0), 40.0, "disk", FRAME)
    table = [[0.0, 1.0], [0.5, 0.8], [1.0, 0.4]]
    light = radial_table_light(fp, (70.0, 60.0), 20.0, table)
    assert light.coverage.sum() == pytest.approx(fp.coverage.sum(), rel=1e-12)
    # Two fully covered pixels at radii 0.707 px and 10.01 px: the table's ratio.
    i1, j1, i2, j2 = 60 - fp.rows.start, 70 - fp.cols.start, 60 - fp.rows.start, 80 - fp.cols.start
    w1 = np.interp(math.hypot(0.5, 0.5) / 20.0, [0, 0.5, 1], [1.0, 0.8, 0.4])
    w2 = np.interp(math.hypot(10.5, 0.5) / 20.0, [0, 0.5, 1], [1.0, 0.8, 0.4])
    assert light.coverage[i2, j2] / light.coverage[i1, j1] == pytest.approx(w2 / w1, rel=1e-12)
    # A flat table is the plain footprint.
    flat = radial_table_light(fp, (70.0, 60.0), 20.0, [[0.0, 2.0], [1.0, 2.0]])
    np.testing.assert_allclose(flat.coverage, fp.coverage, rtol=1e-12)
    with pytest.raises(ValueError, match="zero"):
        radial_table_light(fp, (70.0, 60.0), 20.0, [[0.0, 0.0], [1.0, 0.0]])


@pytest.mark.parametrize("table, why", [([[0.0, 1.0]], "at least two"), ([[0.1, 1.0], [1.0, 1.0]], "from 0 to 1"),
                                        ([[0.0, -1.0], [1.0, 1.0]], ">= 0")])
def test_a_bad_radial_table_is_refused_naming_the_field(table, why):
    effects = {"led_profile": {"profile": "table", "radial_table": table}}
    with pytest.raises(SceneError) as err:
        make_scene(effects=effects)
    assert "effects.led_profile.radial_table" in str(err.value) and why in str(err.value)


# ------------------------------------------------------------------ in a scene
def test_setup_light_conserves_the_led_flux():
    plain = RenderPipeline(make_scene(effects=["ambient"])).setup
    profiled = RenderPipeline(make_scene(effects={"ambient": {}, "led_profile": {"core_sigma_mm": 3.0}})).setup
    assert profiled.led_light.coverage.sum() == pytest.approx(plain.footprint.coverage.sum(), rel=1e-12)
    # The body still hides the same background.
    np.testing.assert_array_equal(profiled.footprint.coverage, plain.footprint.coverage)
    glared = RenderPipeline(make_scene(effects={"ambient": {}, "glare": {"fraction": 0.1}})).setup
    assert glared.led_light.coverage.shape == glared.shape  # the halo reaches the whole frame
    assert 0.9 * plain.footprint.coverage.sum() <= glared.led_light.coverage.sum() <= plain.footprint.coverage.sum()


def test_rendered_led_signal_is_the_light():
    """An LED always ON, noiseless: the profile moves its electrons, their total stays."""
    sections = dict(led={"size_mm": 2.0, "luminous_intensity_cd": 1e-4}, link={"pattern": "on"})
    plain = RenderPipeline(make_scene(effects=[], **sections))
    profiled = RenderPipeline(make_scene(effects={"led_profile": {"core_sigma_mm": 0.6}}, **sections))
    a, b = plain.run_stages(0).electrons, profiled.run_stages(0).electrons
    full_well = plain.setup.scene.camera.full_well_e
    assert a.max() < b.max() < full_well  # a brighter core, nothing clipped
    assert b.sum() == pytest.approx(a.sum(), rel=1e-9)


def test_led_rows_shrink_with_distance_under_glare():
    """With glare the LED's rows are those whose stripes clear the noise: all
    of them at 5 cm on paper-default, fewer at every larger distance."""
    counts = []
    for distance_cm in (5, 10, 20, 30, 40):
        first, last = RenderPipeline(load_scene("paper-default", [f"link.distance_cm={distance_cm}"])).setup.led_rows
        counts.append(last - first + 1)
    assert counts[0] == 1080 and all(a > b for a, b in zip(counts, counts[1:])) and counts[-1] > 0


@pytest.mark.parametrize("other", ["glare", "led_profile"])
def test_motion_with_light_computed_once_per_scene_is_refused_at_load(other):
    with pytest.raises(SceneError, match=f"effects.motion: cannot be combined with {other} yet"):
        load_scene("effect-motion", [f"effects.{other}={{}}"])


# ------------------------------------------------------------ readable rows


def test_row_stripe_snr_of_uniform_rows_is_the_closed_form():
    from rollsim.effects.readable import row_stripe_snr

    gap = np.full((3, 400), 2.0)
    gap[1] = 0.0
    gap[2, :100] = 4.0
    snr = row_stripe_snr(gap, 9.0)
    # sqrt(W) g / sigma: 20 * 2 / 3; a dark row has none; the matched sum adds powers.
    assert snr[0] == pytest.approx(20 * 2 / 3, rel=1e-12)
    assert snr[1] == 0.0
    assert snr[2] == pytest.approx(math.sqrt(100 * 16 / 9 + 300 * 4 / 9), rel=1e-12)


def test_readable_contrast_is_the_decoders():
    from decoder.binarize import MIN_CONTRAST_SIGMA
    from rollsim.effects.readable import READABLE_CONTRAST_SIGMA

    assert READABLE_CONTRAST_SIGMA == MIN_CONTRAST_SIGMA


def test_row_snr_by_blocks_is_the_whole_frames():
    """frame_row_snr works block of rows by block: every row's SNR is, to the
    bit, stripe_gap_and_variance and row_stripe_snr over the whole frame."""
    from rollsim.effects.readable import frame_row_snr, row_stripe_snr, stripe_gap_and_variance

    small = ["camera.width_px=320", "camera.height_px=240"]
    # Rates of one value, and (H, W) maps (vignetting, a colour filter array).
    for overrides in (["link.distance_cm=5"], ["link.distance_cm=30"], [*small, "effects.vignetting=null"],
                      [*small, "effects.bayer=null", "camera.output=rgb8"], [*small, "effects.dark_current=null"]):
        setup = RenderPipeline(load_scene("paper-default", overrides)).setup
        maps = any(o.startswith(("effects.vignetting", "effects.bayer")) for o in overrides)
        assert isinstance(setup.background_e_per_s, np.ndarray) == maps
        gap, variance = stripe_gap_and_variance(setup.led_light.dense(setup.shape), setup.footprint.dense(setup.shape),
                                                setup)
        assert frame_row_snr(setup).tobytes() == row_stripe_snr(gap, variance).tobytes()


def test_readable_rows_follow_the_noise():
    """Without noise effects only quantisation limits the halo (every row of
    paper-default at 30 cm is readable); more ambient light (shot noise)
    shrinks the rows; a brighter LED widens them."""
    def rows(*overrides):
        found = RenderPipeline(load_scene("paper-default", ["link.distance_cm=30", *overrides])).setup.led_rows
        return 0 if found is None else found[1] - found[0] + 1

    base = rows()
    assert rows("effects.shot_noise=false", "effects.read_noise=false") == 1080
    assert 0 < rows("environment.ambient_lux=2000") < base < rows("led.luminous_intensity_cd=0.09")
    assert rows("led.luminous_intensity_cd=0.00001") == 0
