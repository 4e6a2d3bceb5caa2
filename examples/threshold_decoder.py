"""A deliberately simple decoder of one's own: one global threshold.

Written without rollsim's ``decoder`` package, as a decoder author would
start, to show how any decoder is scored against rollsim's ground truth.
From the repository's root, beside rollsim's decoder on a scene where it
reads (most of the PHY-SDUs at ISO 40000) and one where it fails on
purpose (a dim LED in a dark room, where it reads none)::

    rollsim bench stress stress-high-iso stress-low-light --frames 30 --decoder examples.threshold_decoder:decode

or alone, into a render's folder (its own ``decoded.jsonl``)::

    rollsim render stress-high-iso --out run --frames 30
    rollsim decode run --decoder examples.threshold_decoder:decode
    rollsim evaluate run

or from Python, ``rs.decode(frames, decoder=decode)``. It takes the LED's
columns as those brighter than the frame's mid level, averages them row by
row, cuts the profile at the midpoint of its 5th and 95th percentiles, lays
round(run length / rows per chip) chips on each run, and reads a PHY-SDU
after every SYNC with :meth:`rollsim.protocol.PhyFormat.decode_coded`. No
local threshold, no erasures, no clock recovery, no edge-bias correction:
what rollsim's decoder adds is what it gains over this (docs/evaluation.md,
"Anyone's decoder").
"""

from __future__ import annotations

import numpy as np

# Least gap (8-bit levels) between the profile's bright and dark rows for it
# to be read at all: below, it is noise.
MIN_SWING = 8.0


def led_profile(image: np.ndarray) -> np.ndarray | None:
    """Mean of the LED's columns (those brighter than the frame's mid level), row by row."""
    gray = image.astype(np.float64)
    if gray.ndim == 3:
        gray = gray.mean(axis=2)
    columns = gray.mean(axis=0)
    bright = columns > 0.5 * (columns.min() + columns.max())
    if not bright.any() or columns.max() - columns.min() < MIN_SWING:
        return None
    return gray[:, bright].mean(axis=1)


def chips_of(profile: np.ndarray, rows_per_chip: float) -> tuple[np.ndarray, np.ndarray]:
    """Chips (0/1) and the row where each starts, from one global threshold."""
    low, high = np.percentile(profile, [5.0, 95.0])
    level = (profile > 0.5 * (low + high)).astype(np.uint8)
    edges = np.flatnonzero(np.diff(level)) + 1
    starts = np.concatenate([[0], edges])
    lengths = np.diff(np.concatenate([starts, [level.size]]))
    counts = np.maximum(np.rint(lengths / rows_per_chip).astype(np.int64), 0)
    chips = np.repeat(level[starts], counts)
    # Within a run, chip k starts k pitches after the run's first row.
    offsets = np.concatenate([np.arange(c) for c in counts]) if counts.sum() else np.zeros(0)
    rows = np.repeat(starts, counts) + offsets * rows_per_chip
    return chips, rows


def decode(image: np.ndarray, settings) -> list[dict]:
    """PHY-SDUs of one frame as ``decoded.jsonl`` records (rollsim numbers the frame).

    Parameters
    ----------
    image : ndarray
        The frame (8-bit gray, or colour).
    settings : rollsim.stages.decode.DecodeSettings
        ``phy`` (the PHY-SDU format), ``clock_hz`` and ``row_time_s``.
    """
    if settings.clock_hz is None or settings.row_time_s is None:
        raise ValueError("this decoder needs the chip pitch: a scene or --clock-hz and --row-time-us")
    profile = led_profile(image)
    if profile is None:
        return []
    phy = settings.phy
    pitch = 1.0 / (settings.clock_hz * settings.row_time_s)
    chips, rows = chips_of(profile, pitch)
    sync, n = phy.sync, phy.sdu_chips
    if chips.size < n:
        return []
    windows = np.lib.stride_tricks.sliding_window_view(chips, sync.size)
    starts = np.flatnonzero(np.all(windows == sync, axis=1))
    starts = starts[starts + n <= chips.size]
    if starts.size == 0:
        return []
    coded = np.stack([chips[s + phy.sync_chips : s + n] for s in starts])
    found = phy.decode_coded(coded)
    return [
        {"first_row": float(rows[s]), "last_row": float(rows[s + n - 1] + pitch), "sequence": int(seq),
         "bits": "".join("1" if b else "0" for b in payload), "check_ok": bool(ok)}
        for s, seq, payload, ok in zip(starts.tolist(), found.sequence.tolist(), found.payload, found.check_ok.tolist())
    ]
