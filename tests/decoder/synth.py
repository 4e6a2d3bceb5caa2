"""Small synthetic rolling-shutter frames with ground truth (tests only).

Row y of a frame starting at t0 integrates the LED over
[t0 + y·t_row, t0 + y·t_row + t_exp], exactly (``Waveform.exposure``). The
LED's footprint (a disk or a square, with partial pixels at its edge) shows
that row level over a background; optional vignetting, an ambient gradient,
Gaussian and Poisson noise; quantised to uint8 or uint16.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from rollsim.protocol import PhyFormat
from rollsim.transmitter import build_transmitter, message_from_seed

PAPER_ROW_TIME_S = 27.8e-6
PAPER_EXPOSURE_S = 100e-6


@dataclass
class SynthFrame:
    """A synthetic frame and its ground truth.

    Attributes
    ----------
    image : ndarray
    truth : list of dict
        Fully visible PHY-SDUs: ``tx``, ``sequence``, ``bits`` (payload),
        ``first_row_f``, ``last_row_f`` (rollsim's row convention).
    led_rows : (int, int) or None
        First and last row the footprint covers by at least half a pixel.
    row_level : ndarray
        Relative LED level of each row (0 OFF … 1 ON).
    sent : list of dict
        Every PHY-SDU sent while any row of the frame was exposed, as in
        ``truth``: a decode matching one of them is right even where the
        PHY-SDU is only partly visible (its OFF chips past the LED's last
        row are guessed right).
    """

    image: np.ndarray
    truth: list = field(default_factory=list)
    led_rows: tuple | None = None
    row_level: np.ndarray | None = None
    sent: list = field(default_factory=list)


def make_transmitter(phy=None, clock_hz=8000.0, start_s=0.0, pattern="data", seed=1, message_bytes=50):
    """A transmitter as rollsim builds it (RP, r = 1)."""
    phy = PhyFormat(5, 19) if phy is None else phy
    return build_transmitter(phy, message_from_seed(seed, message_bytes), "rp", 1, pattern, clock_hz, start_s)


def footprint_coverage(shape, centre, size, kind="disk", samples=4) -> np.ndarray:
    """Covered fraction of each pixel (supersampled ``samples``² per pixel).

    ``centre`` is (x, y) in pixel coordinates; pixel (x, y) spans
    [x, x+1) × [y, y+1). Only rows and columns near the footprint are
    sampled. Cached: the result is read-only.
    """
    return _coverage(tuple(int(v) for v in shape), tuple(float(v) for v in centre), float(size), kind, int(samples))


@lru_cache(maxsize=32)
def _coverage(shape, centre, size, kind, samples) -> np.ndarray:
    height, width = shape
    cx, cy = centre
    half = 0.5 * size
    cov = np.zeros(shape, dtype=np.float32)
    y0, y1 = max(0, int(np.floor(cy - half))), min(height, int(np.ceil(cy + half)))
    x0, x1 = max(0, int(np.floor(cx - half))), min(width, int(np.ceil(cx + half)))
    if y1 <= y0 or x1 <= x0:
        cov.setflags(write=False)
        return cov
    offsets = (np.arange(samples) + 0.5) / samples
    ys = (np.arange(y0, y1)[:, None] + offsets[None, :]).ravel() - cy
    xs = (np.arange(x0, x1)[:, None] + offsets[None, :]).ravel() - cx
    if kind == "disk":
        inside = (xs[None, :] ** 2 + ys[:, None] ** 2) <= half * half
    else:
        inside = (np.abs(xs)[None, :] <= half) & (np.abs(ys)[:, None] <= half)
    cov[y0:y1, x0:x1] = inside.reshape(y1 - y0, samples, x1 - x0, samples).mean(axis=(1, 3))
    cov.setflags(write=False)
    return cov


def row_levels(tx, n_rows, row_time_s, exposure_s, frame_start_s=0.0) -> np.ndarray:
    """Exact relative exposure of each row: ∫ s dt / t_exp, in [0, 1]."""
    start = frame_start_s + np.arange(n_rows) * row_time_s
    return tx.waveform.exposure(start, start + exposure_s) / exposure_s


def visible_truth(tx, led_rows, row_time_s, exposure_s, frame_start_s=0.0) -> list:
    """PHY-SDUs whose whole span lies in [start of the first LED row, end of
    the last LED row's exposure] (as rollsim's truth does)."""
    if led_rows is None or not tx.sends_data:
        return []
    first, last = led_rows
    visible_from = frame_start_s + first * row_time_s
    visible_to = frame_start_s + last * row_time_s + exposure_s
    tx_ids = tx.emissions_between(visible_from, visible_to)
    starts = tx.emission_start_s(tx_ids)
    ends = starts + tx.sdu_duration_s
    keep = (starts >= visible_from) & (ends <= visible_to)
    phy = tx.phy
    words = tx.codeword_bits(tx_ids)
    out = []
    for i in np.flatnonzero(keep):
        out.append(
            {
                "tx": int(tx_ids[i]),
                "sequence": int(tx.schedule.sequence_numbers(tx_ids[i])),
                "bits": "".join(str(b) for b in words[i, phy.header_bits : phy.data_bits]),
                "first_row_f": (starts[i] - frame_start_s - 0.5 * exposure_s) / row_time_s,
                "last_row_f": (ends[i] - frame_start_s - 0.5 * exposure_s) / row_time_s,
            }
        )
    return out


def synth_frame(
    tx,
    *,
    shape=(1080, 480),
    row_time_s=PAPER_ROW_TIME_S,
    exposure_s=PAPER_EXPOSURE_S,
    frame_start_s=0.0,
    centre=None,
    size=900.0,
    kind="disk",
    on_dn=200.0,
    off_dn=20.0,
    background_dn=60.0,
    noise_dn=0.0,
    poisson_scale=None,
    vignetting=0.0,
    gradient_dn=0.0,
    dtype=np.uint8,
    black_level_dn=0.0,
    channel_gains=None,
    row_gain=None,
    bloom_rows=0.0,
    rng=None,
) -> SynthFrame:
    """Render one synthetic frame.

    Parameters
    ----------
    tx : Transmitter
    shape : (int, int)
        (rows, columns).
    row_time_s, exposure_s, frame_start_s : float
        Rolling-shutter timing in seconds.
    centre : (float, float), optional
        LED centre (x, y) in pixels; default the frame centre.
    size : float
        Disk diameter or square side in pixels.
    kind : {"disk", "square"}
    on_dn, off_dn, background_dn : float
        Levels in DN (above the black level) of the ON LED, OFF LED and
        background.
    noise_dn : float
        Gaussian noise sigma in DN.
    poisson_scale : float, optional
        Electrons per DN for shot noise (None: no shot noise).
    vignetting : float
        Relative gain loss at the frame corners (radial, quadratic).
    gradient_dn : float
        Ambient gradient added to the background, top to bottom.
    dtype : numpy dtype
        uint8 (clipped to 255), uint16 (clipped to 1023, a 10-bit ADC) or
        float (neither rounded nor clipped).
    black_level_dn : float
    channel_gains : sequence of 3 float, optional
        Make an RGB frame: LED signal per channel (background is gray).
    row_gain : ndarray, shape (rows,), optional
        Gain of the LED signal per row (uneven band brightness).
    bloom_rows : float
        Sigma in rows of a vertical Gaussian blur (blooming) applied before
        the noise; with ``on_dn`` above full scale, bands saturate and bleed.
    rng : numpy Generator, optional
    """
    rng = np.random.default_rng(0) if rng is None else rng
    height, width = shape
    centre = (0.5 * width, 0.5 * height) if centre is None else centre
    cov = footprint_coverage(shape, centre, size, kind)
    level = row_levels(tx, height, row_time_s, exposure_s, frame_start_s)
    led_row = off_dn + (on_dn - off_dn) * level
    if row_gain is not None:
        led_row = led_row * np.asarray(row_gain, dtype=np.float64)
    background = background_dn + gradient_dn * np.linspace(0.0, 1.0, height)[:, None]
    led = led_row[:, None] * cov
    base = background * (1.0 - cov)
    if channel_gains is not None:
        gains = np.asarray(channel_gains, dtype=np.float64)
        signal = base[:, :, None] + led[:, :, None] * gains[None, None, :]
    else:
        signal = base + led
    if vignetting:
        yy, xx = np.mgrid[0:height, 0:width]
        r2 = ((xx - 0.5 * width) ** 2 + (yy - 0.5 * height) ** 2) / (0.25 * (width**2 + height**2))
        gain = 1.0 - vignetting * r2
        signal = signal * (gain[:, :, None] if signal.ndim == 3 else gain)
    if bloom_rows:
        from scipy.ndimage import gaussian_filter1d

        signal = gaussian_filter1d(signal, bloom_rows, axis=0, mode="nearest")
    if poisson_scale is not None:
        signal = rng.poisson(np.maximum(signal, 0.0) * poisson_scale) / poisson_scale
    if noise_dn:
        signal = signal + rng.normal(0.0, noise_dn, signal.shape)
    signal = signal + black_level_dn
    if np.dtype(dtype).kind == "f":
        image = signal.astype(dtype)
    else:
        top = 255 if np.dtype(dtype) == np.uint8 else 1023
        image = np.clip(np.rint(signal), 0, top).astype(dtype)
    rows_covered = np.flatnonzero(cov.sum(axis=1) >= 0.5)
    led_rows = (int(rows_covered[0]), int(rows_covered[-1])) if rows_covered.size else None
    truth = visible_truth(tx, led_rows, row_time_s, exposure_s, frame_start_s)
    sdu_rows = tx.sdu_duration_s / row_time_s
    sent = visible_truth(tx, (-int(np.ceil(sdu_rows)), height + int(np.ceil(sdu_rows))), row_time_s, exposure_s, frame_start_s)
    return SynthFrame(image, truth, led_rows, level, sent)


def match(decoded, truth, row_tolerance=2.0, sent=None):
    """Pair decoded PHY-SDUs with truth entries by first row.

    Returns
    -------
    dict
        ``ok``: truth entries decoded ok with the right sequence and bits and
        both rows within tolerance; ``missed``: truth entries without such a
        decode; ``false``: ok decodes matching no truth entry, nor any of
        ``sent`` if given (:attr:`SynthFrame.sent`), or with wrong bits.
    """
    ok, used = [], set()
    for t in truth:
        for i, d in enumerate(decoded):
            if i not in used and d.check_ok and _same(d, t, row_tolerance):
                ok.append(t)
                used.add(i)
                break
    missed = [t for t in truth if t not in ok]
    false = [d for i, d in enumerate(decoded) if d.check_ok and i not in used
             and not any(_same(d, t, row_tolerance) for t in (sent or ()))]
    return {"ok": ok, "missed": missed, "false": false}


def _same(decoded, sent, row_tolerance) -> bool:
    """Whether a decode is this PHY-SDU: its rows within tolerance, its sequence and bits."""
    return (abs(decoded.first_row_f - sent["first_row_f"]) <= row_tolerance
            and abs(decoded.last_row_f - sent["last_row_f"]) <= row_tolerance
            and decoded.sequence == sent["sequence"] and decoded.bits == sent["bits"])


def profile_from_chips(chips, rows_per_chip, exposure_rows=0.8, phase_chips=0.0, on=1.0, off=0.0, noise=0.0, rng=None):
    """Row profile of a chip sequence seen through a rolling shutter, exactly.

    Row y integrates the chips over [y, y + exposure_rows] rows, i.e. chip
    positions [y / rows_per_chip + phase, ...]; rows run until the exposure
    window reaches the last chip.

    Returns
    -------
    values : ndarray of float64
        Mean level over each row's window, plus Gaussian noise.
    """
    chips = np.asarray(chips, dtype=np.float64)
    cumulative = np.concatenate([[0.0], np.cumsum(chips)])

    def integral(u):  # ON chips in [0, u), u in chip units
        c = np.clip(np.floor(u).astype(np.int64), 0, chips.size - 1)
        return cumulative[c] + (u - c) * chips[c]

    n_rows = int(np.floor((chips.size - phase_chips) * rows_per_chip - exposure_rows))
    start = np.arange(n_rows) / rows_per_chip + phase_chips
    width = exposure_rows / rows_per_chip
    level = (integral(start + width) - integral(start)) / width
    values = off + (on - off) * level
    if noise:
        rng = np.random.default_rng(0) if rng is None else rng
        values = values + rng.normal(0.0, noise, values.shape)
    return values


def core_saturated(level, peak_full_scales=6.0):
    """A level (0 … 1 of the ON signal) under a bright core: the gain rises
    from 0.6 at the profile's ends to ``peak_full_scales`` mid-profile, and
    the pixels clip at full scale (1), as an LED with a halo saturates its
    centre. ON runs widen and OFF runs narrow the more the brighter the row."""
    rows = np.arange(level.size)
    gain = 0.6 + (peak_full_scales - 0.6) * np.exp(-(((rows - level.size / 2) / (level.size / 4)) ** 2))
    return np.minimum(level * gain, 1.0)
