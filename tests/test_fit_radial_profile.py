"""rollsim.fit.camera.radial_profile: the LED's radiance profile read from the brightest frame.

A profile is a property of the LED's face, the same above and below its
centre; the stripes' rows lend a ring only what their phase there gives it.
Known answers: a flat face reads as no profile, a face falling as 1 − 0.4 r²
reads as that fall, ring by ring.
"""

import numpy as np
import pytest

from rollsim.fit.camera import PROFILE_MIN_VARIATION, radial_profile
from rollsim.fit.measure import LedDisk, LedRegion

SHAPE = (400, 400)
DISK = LedDisk(200.0, 200.0, 150.0, 300)
REGION = LedRegion(DISK, (slice(73, 328), slice(155, 245)), None)


def _brightest(face, contrast_levels, seed=0, ripple=None):
    """8-bit brightest frame (linear, /255) of an LED ``contrast_levels`` above an OFF level of
    100 at its centre, its face ``face(r)`` (r in radii); ``ripple(y)`` multiplies each row's light."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    r = np.hypot(xx + 0.5 - DISK.centre_x_px, yy + 0.5 - DISK.centre_y_px) / DISK.radius_px
    light = np.where(r <= 1.0, contrast_levels * face(np.minimum(r, 1.0)), 0.0)
    if ripple is not None:
        light = light * ripple(yy)
    frame = np.clip(np.rint(100.0 + light + rng.normal(0.0, 1.5, SHAPE)), 0, 255)
    return frame / 255.0


ON_ROWS = np.zeros(SHAPE[0], dtype=bool)
ON_ROWS[73:328] = True


@pytest.mark.parametrize("seed", range(3))
def test_a_flat_face_a_few_levels_bright_has_no_profile(seed):
    # 4.5 levels above OFF: a ring's median of 8-bit pixels is 4 or 5 levels, a quarter apart.
    assert radial_profile(_brightest(lambda r: np.ones_like(r), 4.5, seed), REGION, ON_ROWS, 100 / 255) is None


def test_a_falling_face_reads_its_fall():
    profile = radial_profile(_brightest(lambda r: 1.0 - 0.4 * r**2, 60.0), REGION, ON_ROWS, 100 / 255)
    assert profile is not None
    radii, values = np.array(profile).T
    inner = (radii > 0.0) & (radii < 0.9)
    # Each ring's mean of 1 − 0.4 r² over its radii, relative to the central ring's.
    edges = np.linspace(0.0, 0.9, 9)
    area_mean = [1.0 - 0.4 * (a**2 + b**2) / 2.0 for a, b in zip(edges[:-1], edges[1:])]
    np.testing.assert_allclose(values[inner], np.array(area_mean) / area_mean[0], atol=0.02)


def test_a_ring_only_the_stripes_lend_is_not_a_profile():
    # A flat face whose rows 30-45 px above the centre are lit more (stripes caught at another
    # phase there): the ring through them reads brighter, but the halves disagree.
    def ripple(y):
        return np.where((y >= 155) & (y < 170), 1.5, 1.0)

    assert radial_profile(_brightest(lambda r: np.ones_like(r), 40.0, ripple=ripple), REGION, ON_ROWS,
                          100 / 255) is None
    # The same rows lit below the centre too: the halves agree, and the ring through them is kept.
    def mirrored(y):
        return np.where(((y >= 155) & (y < 170)) | ((y >= 230) & (y < 245)), 1.5, 1.0)

    profile = radial_profile(_brightest(lambda r: np.ones_like(r), 40.0, ripple=mirrored), REGION, ON_ROWS,
                             100 / 255)
    assert profile is not None and profile[3][1] > 1.0 + PROFILE_MIN_VARIATION
