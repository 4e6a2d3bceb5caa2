"""Lens PSF effects (blur, defocus) against known answers."""

import math
import warnings

import numpy as np
import pytest
from scipy.signal import convolve

from rollsim.errors import RollsimError
from rollsim.optics.footprint import footprint
from rollsim.optics.psf import (
    blurred_footprint,
    circle_of_confusion_m,
    defocus_image_scale,
    disk_kernel,
    gaussian_kernel_1d,
)
from rollsim.render import RenderPipeline
from rollsim.effects.defocus import defocus_diameter_px
from rollsim.optics.footprint import led_rows_from_coverage

from conftest import make_scene

FRAME = (120, 140)
# A "point": a disk of 0.5 px diameter inside pixel (70, 60); its coverage is
# its whole area, pi/16, in that one pixel.
POINT = ((70.5, 60.5), 0.5)
SMALL_LED = dict(led={"size_mm": 1.0}, link={"distance_cm": 10.0})


def _point_image(kernels, frame=FRAME):
    fp = blurred_footprint(POINT[0], POINT[1], "disk", frame, kernels)
    return fp.dense(frame)


def _moments(image, centre=(70, 60)):
    """Total and second moments per axis about ``centre`` (pixel centres)."""
    y, x = np.indices(image.shape)
    total = image.sum()
    return total, (image * (x - centre[0]) ** 2).sum() / total, (image * (y - centre[1]) ** 2).sum() / total


def test_gaussian_point_source_conserves_energy_and_has_variance_sigma_squared():
    k = gaussian_kernel_1d(2.0, truncate_sigma=8.0)
    total, var_x, var_y = _moments(_point_image([(k, k)]))
    assert total == pytest.approx(math.pi / 16, rel=1e-12)
    assert var_x == pytest.approx(4.0, rel=1e-9) and var_y == pytest.approx(4.0, rel=1e-9)
    # The default truncation (5 sigma) keeps the variance within 2e-5.
    k5 = gaussian_kernel_1d(2.0, truncate_sigma=5.0)
    assert _moments(_point_image([(k5, k5)]))[1] == pytest.approx(4.0, rel=2e-5)


@pytest.mark.parametrize("diameter_px", [3.5, 10.0, 25.0])
def test_disk_point_source_conserves_energy_and_has_variance_d2_over_16(diameter_px):
    """The area-weighted disk's variance per axis is D²/16 plus about the
    1/12 px² of one pixel's box (see rollsim.optics.psf)."""
    total, var_x, var_y = _moments(_point_image([disk_kernel(diameter_px)]))
    assert total == pytest.approx(math.pi / 16, rel=1e-12)
    expected = diameter_px**2 / 16 + 1 / 12
    assert var_x == pytest.approx(expected, abs=0.07) and var_y == pytest.approx(var_x, rel=1e-12)


def test_blur_circle_under_one_pixel_is_the_identity():
    assert np.array_equal(disk_kernel(0.0), [[1.0]]) and np.array_equal(disk_kernel(0.999), [[1.0]])
    sharp = footprint((50.3, 40.7), 30.0, "disk", FRAME).dense(FRAME)
    assert np.array_equal(blurred_footprint((50.3, 40.7), 30.0, "disk", FRAME, [disk_kernel(0.8)]).dense(FRAME), sharp)
    # A Gaussian of 1e-3 px is a delta in float64 too.
    k = gaussian_kernel_1d(1e-3)
    assert np.array_equal(blurred_footprint((50.3, 40.7), 30.0, "disk", FRAME, [(k, k)]).dense(FRAME), sharp)


def test_blur_and_defocus_kernels_convolve():
    """Both listed: one pass per kernel equals one pass with their convolution,
    and the variances add."""
    g = gaussian_kernel_1d(1.5, truncate_sigma=8.0)
    disk = disk_kernel(8.0)
    both = _point_image([(g, g), disk])
    combined = convolve(g[:, None] * g[None, :], disk, mode="full")
    assert np.allclose(both, _point_image([combined]), rtol=0, atol=1e-15)
    variance_disk = _moments(_point_image([disk]))[1]
    assert _moments(both)[1] == pytest.approx(1.5**2 + variance_disk, rel=1e-9)


def test_separable_and_full_gaussian_agree_to_float_precision():
    k = gaussian_kernel_1d(2.5)
    args = ((61.2, 58.9), 70.0, "disk", FRAME)
    separable = blurred_footprint(*args, [(k, k)]).dense(FRAME)
    full = blurred_footprint(*args, [k[:, None] * k[None, :]]).dense(FRAME)
    assert np.max(np.abs(separable - full)) < 1e-14


def test_frame_edges_are_exact_light_crosses_them_both_ways():
    """The blurred coverage inside the frame is the crop of the same LED
    blurred on a frame large enough to hold all its light: an LED wholly
    outside the frame spills light in, one near the edge spills light out,
    and no border is reflected or replicated."""
    k = gaussian_kernel_1d(3.0)
    pad = 60
    big_frame = (FRAME[0] + 2 * pad, FRAME[1] + 2 * pad)
    for centre_x, outside in ((-12.0, True), (12.0, False)):
        centre, size = (centre_x, 40.0), 20.0
        inside = blurred_footprint(centre, size, "square", FRAME, [(k, k)]).dense(FRAME)
        big = blurred_footprint((centre_x + pad, 40.0 + pad), size, "square", big_frame, [(k, k)]).dense(big_frame)
        np.testing.assert_allclose(inside, big[pad:-pad, pad:-pad], rtol=0, atol=1e-14)
        assert big.sum() == pytest.approx(size * size, rel=1e-12)  # nothing lost on the large frame
        sharp = footprint(centre, size, "square", FRAME).dense(FRAME).sum()
        if outside:
            assert sharp == 0 and inside.sum() > 1.0  # spilled in
        else:
            assert sharp == size * size and inside.sum() < sharp - 1.0  # spilled out


def test_circle_of_confusion_by_similar_triangles():
    """c = A·|v − v_f|/v from the image distances, against the closed form;
    the bundled defocus scene's 16 px."""
    f, n, d, d_f = 3.97e-3, 2.4, 0.10, 0.15
    v, v_f = f * d / (d - f), f * d_f / (d_f - f)
    by_triangles = (f / n) * abs(v - v_f) / v
    assert circle_of_confusion_m(f, n, d, d_f) == pytest.approx(by_triangles, rel=1e-12)
    assert circle_of_confusion_m(f, n, d, d_f) == pytest.approx(22.485e-6, rel=1e-4)
    assert circle_of_confusion_m(f, n, d, d) == 0.0
    assert defocus_image_scale(f, d, d_f) == pytest.approx(v_f / v, rel=1e-12)
    scene = make_scene(effects={"defocus": {"focus_distance_cm": 15.0}}, link={"distance_cm": 10.0})
    assert defocus_diameter_px(scene, scene.effects.defocus) == pytest.approx(by_triangles / 1.4e-6, rel=1e-12)


def test_defocus_conserves_the_led_light():
    sharp = RenderPipeline(make_scene()).setup
    in_focus = RenderPipeline(make_scene(effects={"defocus": {"focus_distance_cm": 5.0}})).setup
    assert np.array_equal(in_focus.footprint.dense((200, 160)), sharp.footprint.dense((200, 160)))
    assert in_focus.led_e_per_s == sharp.led_e_per_s and in_focus.led_rows == sharp.led_rows
    # A 31 px image in a 51 px blur circle, all inside the frame.
    focused = RenderPipeline(make_scene(**SMALL_LED)).setup
    blurred = RenderPipeline(make_scene(effects={"defocus": {"focus_distance_cm": 5.0}}, **SMALL_LED)).setup
    light = lambda s: s.footprint.coverage.sum() * s.led_e_per_s  # noqa: E731
    assert light(blurred) == pytest.approx(light(focused), rel=1e-12)
    assert blurred.footprint.coverage.max() < 1.0  # the blur circle is larger than the LED's image


def test_led_rows_follow_the_blurred_coverage():
    """A row is an LED row when the LED's light in it adds up to half a fully
    covered pixel, with or without a PSF; blurred, the footprint spans more rows."""
    sharp = RenderPipeline(make_scene(**SMALL_LED)).setup
    pipeline = RenderPipeline(make_scene(effects={"blur": {"sigma_px": 3.0}}, **SMALL_LED))
    setup = pipeline.setup
    assert setup.led_rows == led_rows_from_coverage(setup.footprint.row_coverage(200))
    assert setup.led_rows[0] < sharp.led_rows[0] and setup.led_rows[1] > sharp.led_rows[1]
    assert pipeline.render(0).truth["led_rows"] == list(setup.led_rows)


def test_lens_psf_spreads_the_footprint_but_keeps_the_stripes_sharp():
    """The issue's "vertical blur mixes neighbouring rows" holds for a filter
    applied after capture (demosaicing, ISP sharpening or denoising), not for a
    lens PSF. At any instant the LED is uniformly bright, so row y sees
    (PSF ⊗ coverage)(y, x) · ∫ s dt over its own exposure window: the PSF
    spreads the footprint spatially but never mixes the exposure windows of
    neighbouring rows. Inside the LED, where the blurred coverage is still 1,
    the stripes' row profile is exactly the unblurred one; only the edge
    widens. Blurring the rendered image instead would smear the stripes.
    (Defocus acts the same way; it also rescales the image by v_f/v and so
    its irradiance, see test_defocus_conserves_the_led_light.)"""
    sections = dict(
        camera={"height_px": 200, "width_px": 160},
        led={"size_mm": 1.8, "shape": "square", "luminous_intensity_cd": 2e-4},  # 111 px square
        link={"pattern": "square"},
    )
    sharp = RenderPipeline(make_scene(**sections))
    soft = RenderPipeline(make_scene(effects={"blur": {"sigma_px": 2.0}}, **sections))
    a, b = sharp.render(0).image, soft.render(0).image
    first, last = sharp.setup.led_rows
    rows, cols = slice(first + 15, last - 15), slice(60, 100)
    assert np.array_equal(a[rows, cols], b[rows, cols])
    assert np.ptp(a[rows, 80]) > 200  # real stripes there
    # The edge widens: more columns of the middle row see the LED.
    black = sharp.setup.scene.camera.black_level_dn
    mid = (first + last) // 2
    lit = lambda image: np.count_nonzero(image[mid - 3 : mid + 4].max(axis=0) > black)  # noqa: E731
    assert lit(b) > lit(a) + 6
    # A vertical filter after capture would not keep the stripes.
    from scipy.ndimage import gaussian_filter1d

    filtered = gaussian_filter1d(a.astype(float), 2.0, axis=0)
    assert np.ptp(filtered[rows, 80]) < 0.9 * np.ptp(a[rows, 80])


HARD = {
    "under_one_pixel": dict(led={"size_mm": 0.002}),
    "larger_than_frame": dict(led={"size_mm": 500.0}),
    "just_outside_frame": dict(led={"size_mm": 2.0, "position_px": [-20.0, 90.0]}),
    "far_outside_frame": dict(led={"size_mm": 2.0, "position_px": [-4000.0, 90.0]}),
    "ambient_0_lux": dict(environment={"ambient_lux": 0.0}),
    "saturating": dict(led={"luminous_intensity_cd": 1e6}, environment={"ambient_lux": 1e6}),
}


@pytest.mark.parametrize("output", ["raw16", "rgb8"])
@pytest.mark.parametrize("case", sorted(HARD))
def test_hard_cases_stay_finite_with_every_optical_effect(case, output):
    effects = {"ambient": {}, "shot_noise": {}, "read_noise": {}, "blur": {"sigma_px": 4.0},
               "defocus": {"focus_distance_cm": 8.0}, "vignetting": {}, "bayer": {}}
    sections = {**HARD[case], "camera": {"output": output}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pipeline = RenderPipeline(make_scene(effects=effects, **sections))
        image = pipeline.render(0).image
    assert image.shape == ((200, 160) if output == "raw16" else (200, 160, 3))
    assert image.max() <= (1023 if output == "raw16" else 255)
    cov = pipeline.setup.footprint.coverage
    assert np.all(np.isfinite(cov)) and (cov.size == 0 or (cov.min() >= 0 and cov.max() <= 1))
    for rate in (pipeline.setup.led_e_per_s, pipeline.setup.background_e_per_s, pipeline.setup.face_e_per_s):
        assert np.all(np.isfinite(rate)) and np.all(rate >= 0)
    if case == "just_outside_frame":
        assert cov.sum() > 0  # light spills in from an LED wholly outside the frame
    if case == "far_outside_frame":
        assert cov.size == 0 and pipeline.setup.led_rows is None
    if case == "saturating":
        assert image.min() == image.max()


def test_huge_blur_circle_is_a_clear_error():
    scene = make_scene(effects={"defocus": {"focus_distance_cm": 0.4}}, link={"distance_cm": 1000.0})
    with pytest.raises(RollsimError, match=r"effects.defocus.focus_distance_cm = 0.4: the circle of confusion is \d+ px"):
        RenderPipeline(scene)
