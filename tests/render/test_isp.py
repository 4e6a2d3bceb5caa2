"""The ISP effects against known answers: black clip, tone curves, smoothing,
sharpening and JPEG, and their place in the pipeline."""

import numpy as np
import pytest

from rollsim.errors import SceneError
from rollsim.isp import gaussian_kernel, jpeg_dc_step, jpeg_round_trip, sharpen, smooth
from rollsim.render import RenderPipeline
from rollsim.scene import load_scene
from rollsim.sensor import dn_to_gray8
from rollsim.sensor.tone import ToneCurve, srgb_encode

# ------------------------------------------------------------ black clip, tone


def test_the_black_clip_loses_the_noise_below_the_black_level():
    # 10 bits, black level 64: full scale 959 DN above it.
    dn = np.array([0, 63, 64, 64 + 959, 1023], dtype=np.uint16)
    assert dn_to_gray8(dn, 64, 10).tolist() == [0, 0, 0, 255, 255]
    # A half-scale DN is 127.5 → rounds to 128 (round half to even: 128).
    assert dn_to_gray8(np.array([64 + 479.5 * 2 / 2], dtype=np.uint16), 64, 10)[0] in (127, 128)


def test_srgb_encoding_known_values():
    # IEC 61966-2-1: 0.5 linear encodes to 0.735357; 0.18 to 0.461356; linear toe.
    v = srgb_encode(np.array([0.0, 0.001, 0.0031308, 0.18, 0.5, 1.0]))
    expected = [0.0, 0.01292, 0.040449936, 0.46135613, 0.73535698, 1.0]
    np.testing.assert_allclose(v, expected, atol=2e-6)


def test_gamma_and_table_curves():
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    np.testing.assert_allclose(ToneCurve("gamma", 2.2)(x), x ** (1 / 2.2), rtol=1e-6, atol=1e-7)
    # A measured table sampled from the sRGB curve reproduces it between its points.
    knots = np.linspace(0, 1, 65) ** 2  # dense near black, where the curve bends
    table = tuple(zip(knots.tolist(), srgb_encode(knots).tolist()))
    assert np.max(np.abs(ToneCurve("table", table=table)(x) - srgb_encode(x))) < 4e-3
    identity = ToneCurve("table", table=((0.0, 0.0), (1.0, 1.0)))
    np.testing.assert_allclose(identity(x), x, atol=1e-7)


@pytest.mark.parametrize("table, why", [
    ([[0.0, 0.0]], "at least two"),
    ([[0.1, 0.0], [1.0, 1.0]], "start at 0"),
    ([[0.0, 0.0], [0.5, 0.6], [0.5, 0.7], [1.0, 1.0]], "increase strictly"),
    ([[0.0, 0.0], [0.5, 0.6], [1.0, 0.5]], "must not decrease"),
    ([[0.0, 0.0], [1.0, 1.5]], "lie in [0, 1]"),
])
def test_a_bad_measured_curve_is_refused_naming_the_field(table, why):
    rows = ",".join(f"[{a},{b}]" for a, b in table)
    with pytest.raises(SceneError) as err:
        load_scene("paper-geometric", ["effects.tone_curve.curve=table", f"effects.tone_curve.table=[{rows}]"])
    message = str(err.value)
    assert "effects.tone_curve.table" in message and why in message and "\n" not in message


def test_the_scene_tone_curve_maps_the_output():
    scene = load_scene("paper-geometric", ["effects.tone_curve.curve=srgb", "camera.width_px=64",
                                           "camera.height_px=120", "camera.row_time_us=40"])
    pipeline = RenderPipeline(scene)
    cam = scene.camera
    dn = np.arange(cam.black_level_dn, 2**cam.adc_bits, dtype=np.uint16)
    linear = (dn - cam.black_level_dn) / (2**cam.adc_bits - 1 - cam.black_level_dn)
    expected = np.rint(255 * srgb_encode(linear.astype(np.float32)))
    assert np.array_equal(dn_to_gray8(dn, cam.black_level_dn, cam.adc_bits, pipeline.setup.tone), expected)
    assert "gray8_tone_curve" in pipeline.stage_names


# ------------------------------------------------------------------ filters


# The test frequencies are off whole rows per cycle, so that rounding to 8
# bits does not repeat in step with the sine and bias its amplitude.
def column_sine(frequency_cpp: float, amplitude: float, height: int = 2000, width: int = 8) -> np.ndarray:
    rows = np.arange(height, dtype=np.float64)[:, None]
    return np.rint(128 + amplitude * np.sin(2 * np.pi * frequency_cpp * rows) + 0 * np.arange(width)).astype(np.uint8)


def sine_amplitude(image: np.ndarray, frequency_cpp: float, margin: int = 40) -> float:
    """Least-squares amplitude of the column sine over the interior rows."""
    profile = image.astype(np.float64).mean(axis=1)[margin:-margin]
    rows = np.arange(margin, margin + profile.size)
    basis = np.column_stack([np.sin(2 * np.pi * frequency_cpp * rows), np.cos(2 * np.pi * frequency_cpp * rows),
                             np.ones(profile.size)])
    coef, *_ = np.linalg.lstsq(basis, profile, rcond=None)
    return float(np.hypot(coef[0], coef[1]))


@pytest.mark.parametrize("sigma, frequency", [(1.0, 0.0993), (1.5, 0.1017), (3.0, 0.0513), (2.0, 0.1247)])
def test_smoothing_has_the_gaussian_transfer_function(sigma, frequency):
    image = column_sine(frequency, 60.0)
    before = sine_amplitude(image, frequency)
    after = sine_amplitude(smooth(image, sigma), frequency)
    expected = np.exp(-2 * np.pi**2 * sigma**2 * frequency**2)
    assert after / before == pytest.approx(expected, abs=0.01)


def test_smoothing_down_the_columns_leaves_the_rows_alone():
    rng = np.random.default_rng(1)
    row = rng.integers(0, 256, size=300).astype(np.uint8)
    image = np.tile(row, (50, 1))  # every row the same: nothing changes down a column
    assert np.array_equal(smooth(image, 2.5, 0.0), image)
    assert not np.array_equal(smooth(image, 2.5, 1.0), image)


@pytest.mark.parametrize("sigma", [1.0, 2.0, 4.0])
def test_a_smoothed_step_rises_10_to_90_percent_over_2_563_sigma(sigma):
    image = np.zeros((200, 4), dtype=np.uint8)
    image[100:] = 250
    profile = smooth(image, sigma).astype(np.float64)[:, 0]
    rows = np.arange(profile.size)
    # Interpolated crossings of 10 % and 90 % of the step.
    rise = np.interp(225.0, profile[80:120], rows[80:120]) - np.interp(25.0, profile[80:120], rows[80:120])
    assert rise == pytest.approx(2 * 1.2815516 * sigma, abs=0.25)


@pytest.mark.parametrize("amount, sigma, frequency", [(0.5, 1.0, 0.0993), (1.0, 1.5, 0.0817), (2.0, 1.0, 0.0513)])
def test_sharpening_has_the_unsharp_mask_transfer_function(amount, sigma, frequency):
    image = column_sine(frequency, 30.0)
    gain = sine_amplitude(sharpen(image, amount, sigma), frequency) / sine_amplitude(image, frequency)
    expected = 1 + amount * (1 - np.exp(-2 * np.pi**2 * sigma**2 * frequency**2))
    assert gain == pytest.approx(expected, abs=0.01)


def test_filters_keep_flat_images_and_conserve_the_mean():
    flat = np.full((64, 64), 77, dtype=np.uint8)
    assert np.array_equal(smooth(flat, 2.0, 2.0), flat) and np.array_equal(sharpen(flat, 1.0, 1.0), flat)
    rng = np.random.default_rng(2)
    noise = rng.integers(60, 200, size=(256, 256)).astype(np.uint8)
    assert smooth(noise, 1.5, 1.5).mean() == pytest.approx(noise.mean(), abs=0.3)
    assert sharpen(noise, 0.3, 1.0).mean() == pytest.approx(noise.mean(), abs=0.6)


def exact_blur(image, sigma_rows, sigma_cols):
    """The fixed-point filter in integers: Σ w_i·w_j·I over 2^32, edges mirrored (reflect-101), as float64."""
    from rollsim.isp.filters import WEIGHT_BITS, fixed_point_kernel

    wy = (fixed_point_kernel(gaussian_kernel(sigma_rows)) * 2**WEIGHT_BITS).astype(np.int64)
    wx = (fixed_point_kernel(gaussian_kernel(sigma_cols)) * 2**WEIGHT_BITS).astype(np.int64)
    ry, rx = wy.size // 2, wx.size // 2
    padded = np.pad(image.astype(np.int64), ((ry, ry), (rx, rx)), mode="reflect")
    rows = sum(w * padded[i:i + image.shape[0], :] for i, w in enumerate(wy))
    both = sum(w * rows[:, j:j + image.shape[1]] for j, w in enumerate(wx))
    return both / float(2 ** (2 * WEIGHT_BITS))  # exact: below 2^40 over a power of two


@pytest.mark.parametrize(("sigma_rows", "sigma_cols"), [(1.5, 0.0), (1.0, 1.0), (0.6, 2.3)])
def test_the_blur_is_exact_in_fixed_point(sigma_rows, sigma_cols):
    """The same bits on every CPU: every product and sum of the two passes is exact."""
    from rollsim.isp.filters import _blurred

    image = np.random.default_rng(4).integers(0, 256, (37, 53), dtype=np.uint8)
    assert _blurred(image, sigma_rows, sigma_cols).tobytes() == exact_blur(image, sigma_rows, sigma_cols).tobytes()


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (7, 1), (2, 2), (3, 5), (37, 53), (24, 32, 3)])
@pytest.mark.parametrize(("filter_", "args"), [("smooth", (1.5, 0.0)), ("smooth", (0.6, 2.3)), ("smooth", (5.0, 0.0)),
                                               ("sharpen", (0.5, 1.0)), ("sharpen", (2.0, 3.0)), ("sharpen", (0.0, 1.0))])
def test_the_compiled_filters_give_the_twins_bytes(shape, filter_, args):
    """Fixed point in integers and float64 against OpenCV's exact float64 filter and numpy's rounding,
    taps reaching past tiny images included (reflected again and again)."""
    from rollsim.numerics import jit
    from rollsim.isp import filters

    image = np.random.default_rng(sum(shape)).integers(0, 256, shape, dtype=np.uint8)
    function = getattr(filters, filter_)
    with jit.numpy_only():
        twin = function(image, *args)
    got = function(image, *args)
    assert got.shape == image.shape and got.dtype == np.uint8 and got.tobytes() == twin.tobytes()


def test_the_8_bit_rounding_is_half_to_even_and_saturates():
    from rollsim.isp.filters import _to_uint8

    values = np.array([[0.5, 1.5, 2.5, -0.5, -7.0, 254.5, 255.5, 300.0, 7.5000001, 7.4999999]])
    assert _to_uint8(values).tolist() == [[0, 2, 2, 0, 0, 254, 255, 255, 8, 7]]


@pytest.mark.parametrize("filter_", [lambda image: smooth(image, 1.0), lambda image: sharpen(image, 0.5, 1.0)])
def test_the_filters_take_8_bit_images_only(filter_):
    with pytest.raises(ValueError, match="8-bit"):
        filter_(np.zeros((8, 8), dtype=np.float32))


def test_gaussian_kernel_is_normalised_and_symmetric():
    for sigma in (0.0, 0.3, 1.0, 7.5):
        k = gaussian_kernel(sigma)
        assert k.sum() == pytest.approx(1.0, abs=1e-6) and np.array_equal(k, k[::-1])
    with pytest.raises(ValueError, match="sigma_px"):
        gaussian_kernel(-1.0)


# --------------------------------------------------------------------- JPEG


def dqt_first_entry(quality: int) -> int:
    """The DC step of the first quantisation table in OpenCV's JPEG at ``quality``."""
    import cv2

    ok, data = cv2.imencode(".jpg", np.zeros((8, 8), np.uint8), [cv2.IMWRITE_JPEG_QUALITY, quality])
    raw = data.tobytes()
    at = raw.index(b"\xff\xdb")  # DQT marker; then length (2), precision/id (1), 64 entries
    return raw[at + 5]


@pytest.mark.parametrize("quality", [1, 5, 10, 25, 50, 75, 85, 95, 100])
def test_the_dc_step_is_the_ijg_scaling_of_annex_k(quality):
    assert jpeg_dc_step(quality) == dqt_first_entry(quality)


@pytest.mark.parametrize("quality", [10, 30, 60])
def test_flat_blocks_lose_at_most_a_sixteenth_of_the_dc_step(quality):
    rng = np.random.default_rng(quality)
    levels = rng.integers(10, 246, size=(8, 8))
    image = np.kron(levels, np.ones((8, 8), dtype=np.int64)).astype(np.uint8)  # 8×8 flat blocks, 64×64
    error = np.abs(jpeg_round_trip(image, quality).astype(int) - image.astype(int))
    step = jpeg_dc_step(quality)
    # The bound: half a DC step is step/16 per pixel, plus the IDCT's rounding.
    assert error.max() <= step / 16 + 1
    # Only DC in flat blocks: each block's error is one value (no ringing within it).
    assert all(np.ptp(error[8 * i:8 * i + 8, 8 * j:8 * j + 8]) <= 1 for i in range(8) for j in range(8))
    # And the quantisation is there: coarse steps leave errors that fine ones do not.
    if step >= 32:
        assert error.max() >= 1


def test_jpeg_is_deterministic_and_keeps_colour_order():
    rng = np.random.default_rng(3)
    image = np.zeros((64, 64, 3), dtype=np.uint8)
    image[..., 0] = 200  # red: a BGR mix-up would make it blue
    image += rng.integers(0, 20, size=image.shape).astype(np.uint8)
    once, twice = jpeg_round_trip(image, 80), jpeg_round_trip(image, 80)
    assert np.array_equal(once, twice)
    assert once[..., 0].mean() > 180 and once[..., 2].mean() < 40
    with pytest.raises(ValueError, match="quality"):
        jpeg_round_trip(image, 0)


# ------------------------------------------------------------------ pipeline


def test_isp_stages_run_after_the_output_in_the_isp_order():
    scene = load_scene("effect-isp", ["camera.width_px=96", "camera.height_px=200", "camera.row_time_us=40"])
    names = RenderPipeline(scene).stage_names
    assert names[-4:] == ("gray8_tone_curve", "isp_smoothing", "sharpening", "jpeg")


@pytest.mark.parametrize("effect", ["isp_smoothing", "sharpening", "jpeg"])
def test_isp_effects_refuse_raw_output_naming_the_field(effect):
    with pytest.raises(SceneError) as err:
        load_scene("paper-geometric", ["camera.output=raw16", f"effects.{effect}=null",
                                       "effects.tone_curve=false"])
    assert f"effects.{effect}" in str(err.value) and "camera.output" in str(err.value)


def test_isp_frames_are_the_same_bytes_twice_and_differ_from_plain_ones():
    small = ["camera.width_px=96", "camera.height_px=300", "camera.row_time_us=40"]
    scene = load_scene("effect-isp", small)
    a = RenderPipeline(scene).render(3).image
    b = RenderPipeline(scene).render(3).image
    assert np.array_equal(a, b)
    plain = load_scene("effect-isp", small + ["effects.isp_smoothing=false", "effects.sharpening=false",
                                              "effects.jpeg=false"])
    assert not np.array_equal(a, RenderPipeline(plain).render(3).image)
