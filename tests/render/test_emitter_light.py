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
from rollsim.optics.glare import glare_core_px, glared_light, moffat_kernel, moffat_mass_beyond
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


def linear_convolution(light, kernel):
    """The full linear convolution in float64 (scipy.signal): the reference the float32 transforms approach."""
    from scipy.signal import fftconvolve

    return fftconvolve(light.astype(np.float64), kernel.astype(np.float64), mode="full")


HALO_CASES = [((13, 17), 8.0, 2.0, 40, 55), ((1, 7), 3.0, 1.5, 20, 9), ((7, 1), 0.5, 4.0, 9, 30), ((1, 1), 5.0, 2.0, 12, 12),
              ((310, 310), 208.24, 2.0, 695, 1115)]


@pytest.mark.parametrize(("light_shape", "core", "beta", "ry", "rx"), HALO_CASES)
def test_the_circular_halo_is_the_linear_convolution(light_shape, core, beta, ry, rx):
    """Entry (i mod H, j mod W) is the full convolution's at offset (i, j) from the light's first pixel."""
    light = np.random.default_rng(sum(light_shape)).random(light_shape, dtype=np.float32)
    quadrant = glare.moffat_quadrant(core, beta, ry, rx)
    halo = glare.halo_convolution(light, quadrant)
    full = linear_convolution(light, moffat_kernel(core, beta, ry, rx))
    assert halo.dtype == np.float32
    assert halo.shape[0] >= light_shape[0] + 2 * ry and halo.shape[1] >= light_shape[1] + 2 * rx
    offsets_y = np.arange(full.shape[0]) - ry  # full[k] lies at offset k − radius from the light's first pixel
    offsets_x = np.arange(full.shape[1]) - rx
    wrapped = halo[np.ix_(offsets_y % halo.shape[0], offsets_x % halo.shape[1])]
    # float32 transforms: errors of ~1e-7 of the largest value.
    np.testing.assert_allclose(wrapped, full, rtol=0, atol=4e-7 * full.max())
    # Every other entry is where no offset reaches: zero to round-off.
    rest = np.ones(halo.shape, dtype=bool)
    rest[np.ix_(offsets_y % halo.shape[0], offsets_x % halo.shape[1])] = False
    assert np.abs(halo[rest]).max(initial=0.0) <= 4e-7 * full.max()


# (light shape, core, beta, radius rows, radius columns, window of output offsets): the frame around an LED in its
# centre, near a corner, at an edge, and a window on one side of the light only.
WINDOW_CASES = [((31, 40), 6.0, 2.0, 120, 150, ((-45, 74), (-55, 94))),
                ((12, 9), 4.0, 2.5, 100, 110, ((-2, 97), (-100, 8))),
                ((20, 20), 3.0, 2.0, 60, 60, ((0, 59), (-40, 19))),
                ((5, 6), 2.0, 3.0, 30, 40, ((3, 20), (-30, -2))),
                ((5, 6), 2.0, 2.0, 10, 12, ((0, 60), (-40, 5)))]  # reaching past the kernel's radius


@pytest.mark.parametrize(("light_shape", "core", "beta", "ry", "rx", "window"), WINDOW_CASES)
def test_a_window_of_outputs_takes_a_smaller_transform_and_the_same_values(light_shape, core, beta, ry, rx, window):
    """Only the window's offsets are read (the frame's pixels): they are the linear convolution's, from a transform
    that holds the kernel's offsets they take rather than all it reaches."""
    light = np.random.default_rng(sum(light_shape)).random(light_shape, dtype=np.float32)
    quadrant = glare.moffat_quadrant(core, beta, ry, rx)
    halo = glare.halo_convolution(light, quadrant, window=window)
    full = linear_convolution(light, moffat_kernel(core, beta, ry, rx))  # full[k] at offset k − radius
    (lo_y, hi_y), (lo_x, hi_x) = window
    offsets_y, offsets_x = np.arange(lo_y, hi_y + 1), np.arange(lo_x, hi_x + 1)
    got = halo[np.ix_(offsets_y % halo.shape[0], offsets_x % halo.shape[1])]
    beyond_y = (offsets_y + ry < 0) | (offsets_y + ry >= full.shape[0])  # where the kernel reaches no output
    beyond_x = (offsets_x + rx < 0) | (offsets_x + rx >= full.shape[1])
    inside = ~beyond_y[:, None] & ~beyond_x[None, :]
    expected = np.zeros(got.shape)
    expected[inside] = full[np.ix_(np.clip(offsets_y + ry, 0, full.shape[0] - 1),
                                   np.clip(offsets_x + rx, 0, full.shape[1] - 1))][inside]
    np.testing.assert_allclose(got, expected, rtol=0, atol=4e-7 * full.max())
    default = glare.halo_convolution(light, quadrant)
    assert halo.size < default.size or window == WINDOW_CASES[-1][-1]


def test_the_wrapped_kernel_is_even_so_its_transform_is_real():
    quadrant = glare.moffat_quadrant(6.0, 2.0, 30, 41)
    shape = (80, 100)
    for reach in (None, (12, 41), (30, 3)):
        kernel = glare._wrapped_kernel(quadrant, shape, reach=reach)
        assert np.array_equal(kernel, np.roll(kernel[::-1, ::-1], (1, 1), axis=(0, 1)))  # k[-d] = k[d], circularly
        spectrum = np.fft.rfft2(kernel.astype(np.float64))
        assert np.abs(spectrum.imag).max() <= 1e-12 * np.abs(spectrum.real).max()


@pytest.mark.parametrize("workers", [1, 2])
def test_the_halo_has_the_same_bits_for_any_number_of_threads_and_without_the_extension(workers):
    """pocketfft shares whole transforms out among threads; scipy.fft, where the extension is not found alone,
    runs the same transforms."""
    rng = np.random.default_rng(5)
    light, quadrant = rng.random((40, 31), dtype=np.float32), glare.moffat_quadrant(7.0, 2.5, 77, 90)
    assert glare._pocketfft() is not None  # the fast path is the one these tests check
    direct = glare.halo_convolution(light, quadrant, workers=workers)
    assert direct.tobytes() == glare.halo_convolution(light, quadrant, workers=1).tobytes()
    try:
        glare._pocketfft.cache_clear()
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(glare, "_pocketfft", lambda: None)
            assert glare.halo_convolution(light, quadrant, workers=workers).tobytes() == direct.tobytes()
    finally:
        glare._pocketfft.cache_clear()


def direct_moffat_kernel(core_px, exponent, ry, rx):
    """The kernel with every sample's power taken (not mirrored), scaled by the inscribed disk's sum."""
    from rollsim.numerics.portable_math import power as portable_power

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
def test_moffat_kernel_mirrors_its_quadrant(core_px, exponent, ry, rx):
    """Powers taken on one quadrant and mirrored: every sample the direct formula's, to the scale's last bit."""
    kernel = moffat_kernel(core_px, exponent, ry, rx)
    assert kernel.dtype == np.float32 and kernel.flags.c_contiguous
    np.testing.assert_array_equal(kernel, kernel[::-1, :])
    np.testing.assert_array_equal(kernel, kernel[:, ::-1])
    np.testing.assert_allclose(kernel, direct_moffat_kernel(core_px, exponent, ry, rx), rtol=2.5e-7, atol=0)


def reference_glare(light, frame, eta, core, beta):
    """(1 − η)·L + η·(L ⊗ M) cut to the frame, in float64."""
    height, width = frame
    out = light.dense(frame) * (1.0 - eta)
    ry = max(light.rows.stop, height - light.rows.start)
    rx = max(light.cols.stop, width - light.cols.start)
    halo = linear_convolution(light.coverage, moffat_kernel(core, beta, ry, rx))
    top, left = ry - light.rows.start, rx - light.cols.start
    out += eta * halo[top : top + height, left : left + width]
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
def test_glare_is_the_linear_convolution_cut_to_the_frame(frame, rows, cols, eta, core, beta):
    coverage = np.random.default_rng(sum(rows + cols)).random((rows[1] - rows[0], cols[1] - cols[0]))
    light = Footprint(slice(*rows), slice(*cols), coverage)
    got = glared_light(light, frame, eta, core, beta)
    expected = reference_glare(light, frame, eta, core, beta)
    # The light is convolved in float32 (the halo's relative error ~1e-7).
    np.testing.assert_allclose(got.coverage, expected, rtol=0, atol=4e-7 * expected.max())


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
def test_motion_takes_the_light_computed_once_per_scene(other):
    """The light is moved per frame (tests/render/test_motion_light.py): the pair loads."""
    scene = load_scene("effect-motion", [f"effects.{other}={{}}"])
    assert {"motion", other} <= set(scene.effects.enabled())


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
