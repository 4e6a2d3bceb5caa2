"""Which rows show an LED's stripes above the noise: its readable rows.

An LED's geometric image has sharp edges, and the rows it covers are its
rows. Light spread by the lens's glare (:mod:`rollsim.optics.glare`) has
none: a faint halo reaches every row of the frame, and whether a row shows
the LED's stripes depends on how far they stand out of the noise. rollsim
then calls a row the LED's when an ideal receiver, which combines the row's
pixels each weighted by its own signal-to-noise ratio, sees the ON–OFF gap
at :data:`READABLE_CONTRAST_SIGMA` noise sigmas at least: the contrast the
reference decoder requires of a row's mean (``decoder.binarize``). Its
stripe signal-to-noise ratio is, over the row's pixels j,

    SNR² = Σ_j g_j² / v_j,

with g_j the electrons a fully ON exposure adds to pixel j (up to full
scale) and v_j the noise variance in electrons of pixel j halfway between
OFF and ON: ambient electrons (shot noise), half the gap, the read noise's
variance, the dark current's and the 8-bit frame's quantisation (a twelfth of
its step squared).
Noise effects not listed add nothing (an effect is simulated only when a
scene calls for it; quantisation always applies).

The ``glare`` effect sets a scene's LED rows by this rule. These rows are
the frame's ground truth (which PHY-SDUs are fully visible)
and give the physics' M and N; a real decoder, which averages a region's
pixels with equal weights, reads fewer (see ``decoder.stripe_row_fraction``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rollsim.sensor.adc import full_scale_electrons

if TYPE_CHECKING:
    from rollsim.optics.footprint import Footprint
    from rollsim.render_contract.setup import SceneSetup

# Contrast (ON–OFF gap over the noise sigma of a row) a row's stripes need to
# be read; equal to decoder.binarize.MIN_CONTRAST_SIGMA (tested).
READABLE_CONTRAST_SIGMA = 8.0


def row_stripe_snr(gap_e: np.ndarray, variance_e2: np.ndarray) -> np.ndarray:
    """Stripe signal-to-noise ratio of each row for an ideal receiver.

    Parameters
    ----------
    gap_e : ndarray, shape (H, W)
        ON–OFF gap of each pixel, electrons (≥ 0).
    variance_e2 : ndarray or float
        Noise variance of each pixel, electrons² (> 0).

    Returns
    -------
    ndarray of float64, shape (H,)
        sqrt(Σ_j gap² / variance) per row.
    """
    return np.sqrt(np.sum(np.square(gap_e) / variance_e2, axis=1))


def _on_rows(rate: float | np.ndarray, rows: slice) -> float | np.ndarray:
    """A rate on the frame rows ``rows``: a float as is, an (H, W) map sliced."""
    return rate[rows] if isinstance(rate, np.ndarray) and rate.ndim else rate


def stripe_gap_and_variance(light: np.ndarray, covered: np.ndarray, setup: SceneSetup,
                            rows: slice = slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's ON–OFF gap and noise variance, electrons.

    Parameters
    ----------
    light : ndarray, shape (H, W)
        The LED's light on the sensor, in fully covered pixels at the face's
        mean luminance (``setup.led_light`` laid on the frame).
    covered : ndarray, shape (H, W)
        Where the LED's body hides the background (0 to 1).
    setup : SceneSetup
        Electron rates: one value for every pixel, or (H, W) maps
        (vignetting, a colour filter array).
    rows : slice, default all
        The frame rows ``light`` and ``covered`` hold; the rates' maps are
        cut to them (every pixel's numbers are those of the whole frame).

    Returns
    -------
    gap_e, variance_e2 : ndarray of float64, shape of ``light``
    """
    scene = setup.scene
    cam, listed = scene.camera, set(scene.effects.enabled())
    exposure_s = cam.exposure_s
    led_e_per_s, background_e_per_s, face_e_per_s = (
        _on_rows(rate, rows) for rate in (setup.led_e_per_s, setup.background_e_per_s, setup.face_e_per_s))
    off_e = np.zeros(light.shape)
    # Which noise sources the frame has is which effects are listed.
    if "ambient" in listed:
        off_e += (background_e_per_s * (1.0 - covered) + face_e_per_s * covered) * exposure_s
    if "dark_current" in listed:
        off_e += cam.dark_current_e_per_s * exposure_s
    adc_e = full_scale_electrons(cam.adc_bits, cam.black_level_dn, setup.gain_dn_per_e)
    gap_e = np.clip(np.minimum(light * (led_e_per_s * exposure_s), min(cam.full_well_e, adc_e) - off_e), 0.0, None)
    # The 8-bit frame's step, in electrons: full scale / 255, at least one DN.
    step_e = max(1.0 / setup.gain_dn_per_e, adc_e / 255.0)
    variance = np.full(light.shape, step_e**2 / 12.0)
    if "shot_noise" in listed:
        variance += off_e + 0.5 * gap_e
    if "read_noise" in listed:
        variance += cam.read_noise_e**2
    return gap_e, variance


# Rows per block of readable_rows: a block's temporaries (a dozen float64
# arrays of 32 x 1920 pixels, 0.5 MB each) stay in cache, where frame-sized
# ones (16 MB each at 1080p) cost a trip to memory, and fresh pages, per
# operation: 15 ms instead of 65 ms at 1080p.
_BLOCK_ROWS = 32


def _dense_rows(light: Footprint, rows: slice, width: int) -> np.ndarray:
    """Rows ``rows`` of ``light.dense((H, width))``, without the rest of the frame."""
    out = np.zeros((rows.stop - rows.start, width))
    first, last = max(rows.start, light.rows.start), min(rows.stop, light.rows.stop)
    if first < last:
        out[first - rows.start : last - rows.start, light.cols] = \
            light.coverage[first - light.rows.start : last - light.rows.start]
    return out


def frame_row_snr(setup: SceneSetup) -> np.ndarray:
    """Stripe signal-to-noise ratio of every frame row (:func:`row_stripe_snr` of the frame).

    Computed block of rows by block: every pixel's arithmetic and every
    row's sum are those of the whole frame at once (the same numbers), with
    temporaries small enough to stay in cache.

    Parameters
    ----------
    setup : SceneSetup
        With ``led_light`` set (the LED's light over the frame), or its
        footprint alone, and scalar electron rates.

    Returns
    -------
    ndarray of float64, shape (H,)
        sqrt(Σ_j gap² / variance) per row (gap and variance in electrons).
    """
    spread = setup.led_light if setup.led_light is not None else setup.footprint
    height, width = setup.shape
    snr = np.empty(height)
    for start in range(0, height, _BLOCK_ROWS):
        block = slice(start, min(height, start + _BLOCK_ROWS))
        gap_e, variance = stripe_gap_and_variance(_dense_rows(spread, block, width),
                                                  _dense_rows(setup.footprint, block, width), setup, block)
        snr[block] = row_stripe_snr(gap_e, variance)
    return snr


def readable_rows(setup: SceneSetup) -> tuple[int, int] | None:
    """First and last row whose stripes reach :data:`READABLE_CONTRAST_SIGMA`.

    Parameters
    ----------
    setup : SceneSetup
        With ``led_light`` set (the LED's light over the frame) and scalar
        electron rates.

    Returns
    -------
    (int, int) or None
        None if no row is readable.
    """
    rows = np.flatnonzero(frame_row_snr(setup) >= READABLE_CONTRAST_SIGMA)
    return (int(rows[0]), int(rows[-1])) if rows.size else None
