"""The decoder pipeline: frame → regions → row profiles → chips → PHY-SDUs.

Stages (one module each): :mod:`decoder.region` (LED footprints),
:mod:`decoder.profile` (row means), :mod:`decoder.binarize` (local
threshold, erasures), :mod:`decoder.timing` (clock recovery),
:mod:`decoder.edges` (the rows the LED surely shows) and
:mod:`decoder.framing` (SYNC, line code, check).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from functools import partial
from typing import Any, Callable, Iterable, Iterator, NamedTuple

import cv2
import numpy as np

from rollsim.protocol import PhyFormat, max_run_length
from rollsim.protocol.linecode import chips_per_symbol
from rollsim.protocol.frames import frame_index_from_name

from decoder.binarize import MIN_CONTRAST_SIGMA, Binarized, binarize_profile
from decoder.bloom import spill_fraction, split_at_dips, without_spill
from decoder.edges import SPAN_TOLERANCE_ROWS, led_edges
from decoder.equalise import (MAX_EXPOSURE_CHIPS, MIN_MODULATION_SIGMA, WEAK_MODULATION_SIGMA, detect_chips,
                              stepped_ends)
from decoder.framing import OK, TRUNCATED, SduCandidates, decode_chip_stream, merge_readings
from decoder.io import MAX_FRAME_PIXELS, FrameError, as_frame_array, read_frame
from decoder.order_stats import median, percentiles
from decoder.pitch import choose_grid, edge_grid_fit, merge_candidates, pitch_candidates, edge_energy_period_rows
from decoder.profile import RowProfile, profile_rows, row_profile, stripe_weighted_profile, with_end_rows
from decoder.records import STATUSES, DecodedPhySdu, FrameDecode
from decoder.reach import REACH_CHIPS, striped_ends, striped_reach
from decoder.region import block_means, choose_factor, detect_regions, extended, full_height, room_to_grow
from decoder.timing import (
    MIN_ROWS_PER_CHIP,
    Runs,
    correct_edge_bias,
    edge_bias_chips,
    estimate_rows_per_chip,
    find_runs,
    merge_glitches,
    nominal_rows_per_chip,
    runs_to_chips,
)

# Closing height when the chip pitch is unknown: above the longest OFF run
# (4 chips of 4B6B) up to ~20 rows per chip.
DEFAULT_CLOSE_ROWS = 100
# Least rows of a profile worth binarising: a few chips at the least pitch.
MIN_PROFILE_ROWS = 8


def longest_run_chips(phy: PhyFormat) -> int:
    """Longest run of equal chips in a stream of PHY-SDUs (upper bound).

    The SYNC's ON chips plus up to R ON chips of the data before it.
    """
    return phy.sync_chips - 1 + max_run_length(phy.line_code)


def reach_window_rows(phy: PhyFormat, rows_per_chip: float) -> int:
    """Rows of the LED that surely hold an edge of its stripes: the longest run of equal chips and one more."""
    return int(np.ceil((longest_run_chips(phy) + 1) * rows_per_chip))


def envelope_window_rows(phy: PhyFormat, rows_per_chip: float) -> int:
    """Envelope window (odd, rows): more than twice the longest run."""
    rows = (2 * longest_run_chips(phy) + 1) * rows_per_chip
    return 2 * int(rows // 2) + 1


def closing_rows(phy: PhyFormat, rows_per_chip: float | None) -> float:
    """Height (rows) of the closing that joins an LED's bright bands."""
    if rows_per_chip is None:
        return float(DEFAULT_CLOSE_ROWS)
    # The longest OFF run, one chip of margin, and a few rows for the blur.
    return (max_run_length(phy.line_code) + 1) * rows_per_chip + 8.0


def coarse_rows_per_chip(profile: RowProfile, min_contrast: float = MIN_CONTRAST_SIGMA) -> float | None:
    """Rows per chip of a profile whose chip pitch is unknown.

    Binarise with a wide window (a tenth of the profile, at least 31 rows),
    then fit a chip pitch to the run lengths.
    """
    n = len(profile)
    window = max(31, 2 * (n // 20) + 1)
    levels = binarize_profile(profile.values, profile.noise, window, 0.0, min_contrast)
    return estimate_rows_per_chip(find_runs(levels.level, levels.q))


def profile_rows_per_chip(profile: RowProfile, phy: PhyFormat, min_contrast: float = MIN_CONTRAST_SIGMA) -> float | None:
    """Rows per chip of a profile whose chip pitch is unknown (see :mod:`decoder.pitch`).

    The candidates (the edge-energy spectrum's and the run lengths') are
    each fitted as a chip grid to the edges of the profile binarised at the
    finest of them; the longest grid the edges lie on is the pitch
    (:func:`decoder.pitch.choose_grid`).

    Returns
    -------
    float or None
        None when no candidate's grid fits the edges.
    """
    period = edge_energy_period_rows(profile.values)
    coarse = coarse_rows_per_chip(profile, min_contrast)
    if period is None and coarse is None:
        return None
    # Binarised at half the strongest line's period (or the run lengths'
    # pitch, if finer), the profile keeps every edge that a grid must explain.
    finest = min(p for p in (None if period is None else max(0.5 * period, MIN_ROWS_PER_CHIP), coarse) if p is not None)
    _, runs = binarise_at_pitch(profile, phy, finest, min_contrast)
    symbol_chips = chips_per_symbol(phy.line_code)[0]
    spectral = [] if period is None else pitch_candidates(period, symbol_chips, len(profile) / 4.0)
    candidates = merge_candidates([*spectral, coarse])
    chosen = choose_grid((guess, edge_grid_fit(runs, guess)) for guess in candidates)
    return None if chosen is None else chosen.rows_per_chip


def binarise_at_pitch(profile: RowProfile, phy: PhyFormat, rows_per_chip: float,
                      min_contrast: float = MIN_CONTRAST_SIGMA) -> tuple[Binarized, Runs]:
    """Levels and runs of a profile, binarised for a chip pitch (rows).

    The envelope window and smoothing suit the pitch; the runs have their
    edge bias corrected and glitches shorter than half a chip merged.
    """
    levels = binarize_profile(
        profile.values,
        profile.noise,
        envelope_window_rows(phy, rows_per_chip),
        smooth_rows=smoothing_rows(profile, rows_per_chip),
        min_contrast=min_contrast,
        min_run_rows=0.5 * rows_per_chip,
    )
    return levels, _corrected(find_runs(levels.level, levels.q), rows_per_chip)


def _corrected(runs: Runs, rows_per_chip: float) -> Runs:
    """Runs with their edge bias corrected, then glitches shorter than half a chip merged."""
    # Before glitches are merged: under saturation a lone OFF chip can look
    # shorter than half a chip until the edge bias is taken out.
    return merge_glitches(correct_edge_bias(runs, edge_bias_chips(runs, rows_per_chip), rows_per_chip), rows_per_chip)


def bloomed_runs(profile: RowProfile, levels: Binarized, rows_per_chip: float) -> Runs | None:
    """The runs of binarised levels with blooming's spill taken out (:mod:`decoder.bloom`); None if none shows.

    An OFF chip the spill flooded in part is split out of its ON run first;
    then each ON run loses the spilled fraction of its length, before
    saturation's constant bias is measured.
    """
    noise_q = np.divide(profile.noise, levels.half_gap, out=np.full(len(profile), np.inf), where=levels.half_gap > 0)
    runs = find_runs(levels.level, levels.q)
    split = split_at_dips(runs, levels.level, levels.q, noise_q, rows_per_chip)
    spilled = spill_fraction(split, rows_per_chip)
    if spilled == 0.0:
        return None
    return _corrected(without_spill(split, spilled), rows_per_chip)


# Exposures longer than this many chips are decoded by sequence detection
# (decoder.equalise) only: thresholding reads isolated chips up to about
# 1.4 chips but from about one chip on it corrupts many (43 % ok at exactly
# one chip on paper-default). Shorter exposures are thresholded first and
# detected again where that left a candidate failed or found none.
LONG_EXPOSURE_CHIPS = 0.9
# Fewer rows than chips cannot determine the chips (a little under one row
# per chip is a row time slightly off).
MIN_DETECTED_ROWS_PER_CHIP = 0.95
# Chips shorter than this many blocks hardly show in the block image.
UNRESOLVED_CHIP_BLOCKS = 0.75


# A chip decided ON with at least this confidence (its least-squares value,
# 1 = on the ON level, 0 = at the midpoint) surely shows the LED.
CONFIDENT_ON_CHIP = 0.45


def equalised_chips(profile: RowProfile, phy: PhyFormat, rows_per_chip: float, exposure_rows: float):
    """Chips of a profile seen through a long exposure, the rows a whole PHY-SDU must lie in, and the sure rows.

    The span runs from the first to the last chip decided ON with
    confidence (as thresholding's runs from the first to the last confident
    ON run, :func:`decoder.edges.led_edges`): past the LED's last rows an OFF chip looks
    like the background, so the chips there are not the LED's to claim.
    Rows whose stripes stand out of the noise by
    :data:`~decoder.equalise.WEAK_MODULATION_SIGMA` are read; those that
    stand out by :data:`~decoder.equalise.MIN_MODULATION_SIGMA` are sure.
    Rows past a level step at the profile's ends
    (:func:`~decoder.equalise.stepped_ends`: the region's margin over a
    face darker or brighter than its surroundings) are not looked at.

    Returns
    -------
    (ChipStream, (first, last) or None, ndarray of bool)
        The span (profile rows) is None when no chip is surely ON; the
        last, per profile row, whether it is sure.
    """
    first, stop = stepped_ends(profile.values, rows_per_chip)
    found = detect_chips(profile.values[first:stop], phy, rows_per_chip, exposure_rows,
                         min_modulation_sigma=WEAK_MODULATION_SIGMA)
    sure = np.zeros(len(profile), dtype=bool)
    sure[first:stop] = found.modulation > MIN_MODULATION_SIGMA
    chips = replace(found.chips, start=found.chips.start + first, end=found.chips.end + first)
    on = np.flatnonzero((chips.values == 1) & (chips.confidence >= CONFIDENT_ON_CHIP))
    if on.size == 0:
        return chips, None, sure
    return chips, (chips.start[on[0]] - SPAN_TOLERANCE_ROWS, chips.end[on[-1]] + SPAN_TOLERANCE_ROWS), sure


def passed_or_sure(found: SduCandidates, sure: np.ndarray) -> SduCandidates:
    """The candidates that passed their check, or lie in sure rows only.

    A failed candidate touching a row whose stripes barely stand out of the
    noise is dropped: there a failure says nothing about the LED.
    """
    if len(found) == 0:
        return found
    cumulative = np.concatenate([[0], np.cumsum(~sure)])
    first = np.clip(np.floor(found.first_row).astype(np.int64), 0, sure.size)
    last = np.clip(np.ceil(found.last_row).astype(np.int64) + 1, 0, sure.size)
    unsure = cumulative[last] - cumulative[first] > 0
    return found.select(found.check_ok | ~unsure)


# Row noise, as a fraction of the stripe contrast, above which the profile is
# smoothed before binarisation.
SMOOTH_NOISE_FRACTION = 0.05


def smoothing_rows(profile: RowProfile, rows_per_chip: float) -> float:
    """Sigma (rows) of the Gaussian smoothing before binarisation.

    A sixth of a chip averages noise without moving edges; but under
    saturation a lone OFF chip may be a single dark row, which that
    smoothing would halve. So a profile whose row noise is small against its
    contrast (the usual case: each row averages hundreds of pixels) is not
    smoothed at all.
    """
    low, high = percentiles(profile.values, (5.0, 95.0))
    if median(profile.noise) < SMOOTH_NOISE_FRACTION * (high - low):
        return 0.0
    return rows_per_chip / 6.0


def decode_profile(
    profile: RowProfile,
    phy: PhyFormat,
    rows_per_chip: float | None = None,
    *,
    frame_index: int = 0,
    region: int = 0,
    include_failed: bool = True,
    include_truncated: bool = False,
    min_contrast: float = MIN_CONTRAST_SIGMA,
    exposure_rows: float | None = None,
) -> list[DecodedPhySdu]:
    """Decode the PHY-SDUs of one row profile.

    Parameters
    ----------
    profile : RowProfile
    phy : PhyFormat
    rows_per_chip : float, optional
        Nominal chip pitch in rows; estimated from the profile if None.
    frame_index, region : int
        Copied into the records.
    include_failed : bool
        Also report candidates that failed the line code, the check or hit
        an erasure (``check_ok`` False).
    include_truncated : bool
        Also report candidates reaching past the LED's rows.
    min_contrast : float
        Erasure threshold, in noise sigmas (see :mod:`decoder.binarize`).
    exposure_rows : float, optional
        Exposure in rows (exposure time / row time). With the chip pitch, an
        exposure longer than :data:`LONG_EXPOSURE_CHIPS` chips is decoded
        by sequence detection (:mod:`decoder.equalise`).

    Returns
    -------
    list of DecodedPhySdu
        In row order.
    """
    options: dict[str, Any] = {"frame_index": frame_index, "region": region, "include_failed": include_failed,
                               "include_truncated": include_truncated, "min_contrast": min_contrast,
                               "exposure_rows": exposure_rows}
    return _decode_profile_levels(profile, phy, rows_per_chip, **options)[0]


def _thresholded_candidates(profile: RowProfile, runs: Runs, levels: Binarized, pitch: float, phy: PhyFormat):
    """PHY-SDU candidates of a profile's thresholded levels, and the rows its stripes are surely seen in; (None, None) if never."""
    edges = led_edges(runs, levels, pitch, profile.values, profile.noise)
    if edges is None:
        return None, None
    cut_left, cut_right, span, striped = edges
    return decode_chip_stream(runs_to_chips(runs, pitch, levels.q, cut_left, cut_right), phy, span), striped


def _read_through_blooming(profile: RowProfile, levels: Binarized, pitch: float, phy: PhyFormat, found, span):
    """Thresholding's reading, joined by what the runs read with blooming's spill taken out, if a spill shows.

    Only where thresholding left PHY-SDUs unread: the spill's fit costs a
    tenth of a millisecond, and a profile read whole shows none worth
    taking out.
    """
    bloomed = bloomed_runs(profile, levels, pitch)
    if bloomed is None:
        return found, span
    second, second_span = _thresholded_candidates(profile, bloomed, levels, pitch, phy)
    return _joined(found, span, second, second_span, phy.sdu_chips * pitch)


def _joined(found, span, second, second_span, sdu_rows: float):
    """A reading and its span joined by a second one's: what only the second read (:func:`merge_readings`), and
    the union of the spans; the second alone where the first found nothing."""
    if found is None or span is None:
        return second, second_span
    if second_span is None:
        return found, span
    if second is not None:
        found = merge_readings(found, second, sdu_rows)
    return found, (min(span[0], second_span[0]), max(span[1], second_span[1]))


def _passed(found) -> int:
    """Candidates whose check passed (0 for none)."""
    return 0 if found is None else int(np.count_nonzero(found.check_ok))


# Chips by which a failed candidate must overlap a passed one to be taken as
# a SYNC pattern matched inside it. PHY-SDUs never overlap, but a real
# neighbour cut by the LED's first or last row is laid at the nominal pitch
# from its one real edge and may be found a couple of chips off (2.2 on a
# stress-strong-ambient frame, whose cut neighbour the second look reads).
OVERLAP_CHIPS = 3


def _all_read(found, pitch: float, sdu_chips: int) -> bool:
    """Whether every candidate inside the LED's rows passed, and there is one.

    A failed candidate overlapping a passed one by more than
    :data:`OVERLAP_CHIPS` chips is a SYNC pattern matched in that PHY-SDU's
    rows (or a cut one's beside it), not another PHY-SDU, and does not
    count.
    """
    if found is None or not found.check_ok.any():
        return False
    passed = found.first_row[found.check_ok]
    apart = np.min(np.abs(found.first_row[:, None] - passed[None, :]), axis=1)
    inside = apart < (sdu_chips - OVERLAP_CHIPS) * pitch
    return bool(np.all(found.check_ok | (found.status == TRUNCATED) | inside))


def _worth_a_second_look(found, n_rows: int, pitch: float, sdu_chips: int) -> bool:
    """Whether thresholding left PHY-SDUs of a profile unread.

    A profile too short for a whole PHY-SDU (``sdu_chips`` chips of
    ``pitch`` rows) has none to read. Otherwise: a candidate failed or none
    passed (:func:`_all_read`), or fewer passed than whole slots fit on the
    grid the passed ones fix (:func:`_slots_in_rows`; never fewer than
    ⌊n/S⌋ − 1 for PHY-SDUs S rows long: weak stripes are erased, not
    failed, and a fading halo ends where thresholding stops seeing the LED
    before sequence detection does).
    """
    sdu_rows = sdu_chips * pitch
    if n_rows < sdu_rows:
        return False
    if not _all_read(found, pitch, sdu_chips):
        return True
    return _passed(found) < _slots_in_rows(found.first_row[found.check_ok], sdu_rows, n_rows, pitch)


def _slots_in_rows(passed_first_rows: np.ndarray, sdu_rows: float, n_rows: int, pitch: float) -> int:
    """Whole PHY-SDU slots in a profile of ``n_rows`` rows, on the grid of its passed PHY-SDUs.

    PHY-SDUs follow each other every ``sdu_rows`` rows at least, so the
    first passed one fixes the phase of the slots, and a slot reaching past
    the profile's ends by no more than a chip (the run-edge tolerance)
    counts.
    """
    phase = float(np.min(passed_first_rows)) % sdu_rows
    first = phase - sdu_rows * ((phase + pitch) // sdu_rows)   # the earliest slot start ≥ −pitch
    return int(max(0, (n_rows + pitch - first) // sdu_rows))


def _decode_profile_levels(profile, phy, rows_per_chip, *, frame_index, region, include_failed, include_truncated,
                           min_contrast, exposure_rows=None, weighted=None,
                           measure_span=False) -> tuple[list[DecodedPhySdu], Binarized | None, tuple[int, int] | None]:
    """:func:`decode_profile`, the levels it binarised (None when it found no chip pitch), and
    the first and last frame row where it surely saw the LED's stripes (None if nowhere).

    ``weighted``, if given, returns the same rows' stripe-weighted profile
    (:func:`decoder.profile.stripe_weighted_profile`, or None) for the
    sequence detector; it is called only when the detector runs.

    With ``measure_span`` and the exposure known, the detector always runs
    on a profile that holds a whole PHY-SDU, and the rows it sees join
    thresholding's, whether or not its reading was needed: the measured
    stripe rows do not depend on how well thresholding did."""
    # A region too short for a PHY-SDU may still show stripes (the LED's
    # rows are measured even where no PHY-SDU fits); fewer rows than the
    # shortest run pattern cannot.
    if len(profile) < MIN_PROFILE_ROWS:
        return [], None, None
    pitch = rows_per_chip if rows_per_chip is not None else profile_rows_per_chip(profile, phy, min_contrast)
    if pitch is None:
        return [], None, None
    if exposure_rows is not None and exposure_rows > MAX_EXPOSURE_CHIPS * pitch:
        # Longer than the detector's memory allows: thresholding alone
        # (which reads nothing there, but fails no frame).
        exposure_rows = None
    # Finer than thresholding's least pitch, chips of a row or so are still
    # read by sequence detection over the known exposure: each row mixes at
    # most two or three chips, with weights the pitch and exposure give.
    fine = exposure_rows is not None and MIN_DETECTED_ROWS_PER_CHIP <= pitch < MIN_ROWS_PER_CHIP
    if not (pitch >= MIN_ROWS_PER_CHIP or fine):
        return [], None, None
    levels, runs = (None, None) if fine else binarise_at_pitch(profile, phy, pitch, min_contrast)
    long_exposure = exposure_rows is not None and (fine or exposure_rows > LONG_EXPOSURE_CHIPS * pitch)
    found, span = None, None
    sdu_rows = phy.sdu_chips * pitch
    if not long_exposure and runs is not None and levels is not None:
        found, span = _thresholded_candidates(profile, runs, levels, pitch, phy)
        if _worth_a_second_look(found, len(profile), pitch, phy.sdu_chips):
            found, span = _read_through_blooming(profile, levels, pitch, phy, found, span)
    second_look = exposure_rows is not None and (long_exposure or _worth_a_second_look(found, len(profile), pitch, phy.sdu_chips))
    # (Not a second look on a profile holding a whole PHY-SDU: thresholding read every one.)
    measure_only = measure_span and exposure_rows is not None and not second_look and len(profile) >= sdu_rows
    if second_look or measure_only:
        # A second look, by sequence detection over the known smear: it
        # reads what thresholding cannot (weak stripes, a long exposure);
        # what only it reads joins thresholding's reading.
        detect = (weighted() if weighted is not None else None) or profile
        chips, second_span, sure = equalised_chips(detect, phy, pitch, exposure_rows)
        second = None if second_span is None or measure_only else passed_or_sure(
            decode_chip_stream(chips, phy, second_span), sure)
        found, span = _joined(found, span, second, second_span, sdu_rows)
    if found is None or span is None:
        return [], levels, None
    seen = (profile.first_row + int(round(span[0])), profile.first_row + int(round(span[1])))
    keep = found.status != TRUNCATED if not include_truncated else np.ones(len(found), dtype=bool)
    if not include_failed:
        keep &= found.check_ok
    offset = float(profile.first_row)
    payload_bits = ["".join("1" if b else "0" for b in row) for row in found.payload[keep].tolist()]
    sdus = [
        DecodedPhySdu(
            frame=int(frame_index),
            first_row_f=offset + float(first),
            last_row_f=offset + float(last),
            sequence=int(seq),
            bits=bits,
            check_ok=bool(status == OK),
            confidence=float(conf),
            status=STATUSES[int(status)],
            region=int(region),
        )
        for first, last, seq, bits, status, conf in zip(
            found.first_row[keep].tolist(),
            found.last_row[keep].tolist(),
            found.sequence[keep].tolist(),
            payload_bits,
            found.status[keep].tolist(),
            found.confidence[keep].tolist(),
        )
    ]
    return sdus, levels, seen


def decode_frame(
    image,
    phy: PhyFormat,
    clock_hz: float | None = None,
    row_time_s: float | None = None,
    frame_index: int = 0,
    *,
    include_failed: bool = True,
    include_truncated: bool = False,
    min_contrast: float = MIN_CONTRAST_SIGMA,
    block_px: int = 4,
    max_regions: int = 8,
    exposure_s: float | None = None,
) -> list[DecodedPhySdu]:
    """Decode the PHY-SDUs of one frame.

    Parameters
    ----------
    image : array_like
        ``(H, W)`` gray (uint8, uint16 or float) or ``(H, W, 3|4)`` colour.
    phy : PhyFormat
        The PHY-SDU layout (shared with the transmitter).
    clock_hz : float, optional
        Chip rate in Hz.
    row_time_s : float, optional
        Row time in seconds. With ``clock_hz`` it gives the nominal chip
        pitch 1 / (f·t_row) rows; without either, the pitch is estimated
        from each profile's run lengths.
    frame_index : int
        Copied into the records.
    include_failed : bool
        Report candidates whose check failed (``check_ok`` False).
    include_truncated : bool
        Report candidates reaching past the LED's rows (never ``check_ok``).
    min_contrast : float
        Erasure threshold in noise sigmas.
    block_px : int
        Block size of the detection image, in pixels.
    max_regions : int
        LED regions decoded at most.
    exposure_s : float, optional
        Exposure time in seconds (a PNG from rollsim says it:
        ``exposure_us``). With ``clock_hz`` and ``row_time_s``, an exposure
        longer than :data:`LONG_EXPOSURE_CHIPS` chips is decoded by
        sequence detection over the known smear (:mod:`decoder.equalise`),
        and so are chips finer than thresholding's 1.2 rows (down to
        :data:`MIN_DETECTED_ROWS_PER_CHIP`); without it, thresholding reads
        exposures up to about 1.4 chips and nothing finer than 1.2 rows.

    Returns
    -------
    list of DecodedPhySdu
        Sorted by region, then row. Empty when the frame shows no LED.

    Raises
    ------
    FrameError
        The array is not a frame (see :func:`decoder.io.as_frame_array`).
    """
    options: dict[str, Any] = {"include_failed": include_failed, "include_truncated": include_truncated,
                               "min_contrast": min_contrast, "exposure_rows": exposure_rows(exposure_s, row_time_s)}
    decoded: list[DecodedPhySdu] = []
    for index, read in enumerate(_region_profiles(image, phy, clock_hz, row_time_s, block_px, max_regions,
                                                  options["exposure_rows"])):
        decoded.extend(_decode_profile_levels(read.profile, phy, read.pitch, frame_index=frame_index, region=index,
                                              weighted=read.weighted, **options)[0])
    return decoded


def exposure_rows(exposure_s: float | None, row_time_s: float | None) -> float | None:
    """Exposure in rows, exposure_s / row_time_s; None unless both are known."""
    if exposure_s is None or row_time_s is None:
        return None
    if not (np.isfinite(exposure_s) and exposure_s > 0):
        raise ValueError(f"exposure_s must be a finite number > 0, got {exposure_s}")
    return float(exposure_s) / float(row_time_s)


def bridge_rows(phy: PhyFormat, rows_per_chip: float | None, exposure_rows: float | None) -> float:
    """Longest lit band without stripes (rows) that may split an LED's footprint: a PHY-SDU's rows.

    Only an exposure the sequence detector reads (longer than
    :data:`LONG_EXPOSURE_CHIPS` chips) flattens runs of chips into such a
    band (:mod:`decoder.bridging`); otherwise 0, and no part is joined.
    """
    if rows_per_chip is None or exposure_rows is None or exposure_rows <= LONG_EXPOSURE_CHIPS * rows_per_chip:
        return 0.0
    return phy.sdu_chips * rows_per_chip


def _region_profiles(image, phy: PhyFormat, clock_hz, row_time_s, block_px: int, max_regions: int,
                     exposure_rows: float | None = None):
    """Yield a :class:`RegionProfiles` per LED region.

    The stripe-weighted profile is computed only if asked for. ``exposure_rows``
    (exposure / row time), if known, lets a long exposure's flat bands join
    a footprint's parts (:func:`bridge_rows`)."""
    frame = as_frame_array(image)
    pitch = nominal_rows_per_chip(clock_hz, row_time_s) if clock_hz is not None and row_time_s is not None else None
    blocks = block_means(frame, choose_factor(frame.shape[:2], block_px))
    regions = detect_regions(blocks, closing_rows(phy, pitch), max_regions=max_regions, rows_per_chip=pitch,
                             bridge_rows=bridge_rows(phy, pitch, exposure_rows))
    if pitch is None:
        # One row time and one clock make one chip pitch for the whole frame:
        # estimate it from the regions found without it, then find the
        # regions again as if it had been given.
        pitch = frame_rows_per_chip([row_profile(blocks, region) for region in regions], phy)
        if pitch is not None:
            regions = detect_regions(blocks, closing_rows(phy, pitch), max_regions=max_regions, rows_per_chip=pitch)
    if regions and pitch is not None and pitch < UNRESOLVED_CHIP_BLOCKS * blocks.factor:
        # A block of `factor` rows averages most of a chip this fine away,
        # so the modulation map finds the LED's bright core but not its
        # faint rows above and below (a glare halo): the largest region
        # takes every row of the frame, and the readers' erasures keep to
        # the rows whose stripes show.
        regions = [full_height(regions[0], blocks.height), *regions[1:]]
    room = [(0, 0)] * len(regions) if pitch is None else room_to_grow(regions, blocks.height,
                                                                      int(round(REACH_CHIPS * pitch)))
    for found, (above, below) in zip(regions, room):
        found_profile = row_profile(blocks, found)
        found_weighted = _weighted(blocks, found, pitch, found_profile.channel)
        region, profile, weighted = found, found_profile, found_weighted
        if pitch is not None and (above or below):
            reached = _reached(blocks, found, found_profile, pitch, phy, above, below)
            if reached is not None:
                region, profile = reached
                weighted = _weighted(blocks, region, pitch, profile.channel)
        yield RegionProfiles(blocks.block_col_span(region.block_cols), profile, pitch, weighted,
                             found_profile, found_weighted)


def _reached(blocks, found, profile: RowProfile, pitch: float, phy: PhyFormat, above: int, below: int):
    """``found`` and its ``profile`` with the rows past its ends that its stripes reach (:mod:`decoder.reach`),
    looking at most ``above`` and ``below`` rows out; None if they reach none."""
    window = reach_window_rows(phy, pitch)
    top, bottom = striped_ends(profile, pitch, window)
    above, below = above if top else 0, below if bottom else 0
    if not (above or below):
        return None
    looked_at = with_end_rows(blocks, profile, found, above, below)
    above, below = striped_reach(looked_at, found.rows, pitch, window)
    if not (above or below):
        return None
    region = extended(found, above, below)
    return region, profile_rows(looked_at, region.rows)


class RegionProfiles(NamedTuple):
    """One LED region's profiles, as :func:`_region_profiles` yields them.

    Attributes
    ----------
    cols : slice
        The region's frame columns.
    profile : RowProfile
        Row means over the rows read: the region's, and the rows past its
        ends that its stripes reach (:mod:`decoder.reach`).
    pitch : float or None
        Nominal rows per chip.
    weighted : callable or None
        Gives the same rows' :func:`decoder.profile.stripe_weighted_profile`.
    found_profile : RowProfile
        Row means over the rows the region tests found, before the reach:
        what the stripe rows are measured on (:func:`inspect_frame`);
        ``profile`` itself where the reach added none.
    found_weighted : callable or None
        As ``weighted``, for those rows.
    """

    cols: slice
    profile: RowProfile
    pitch: float | None
    weighted: Callable | None
    found_profile: RowProfile
    found_weighted: Callable | None


def _weighted(blocks, region, pitch: float | None, channel: int | None) -> Callable | None:
    """A callable giving the region's stripe-weighted profile in ``channel``; None without a pitch."""
    return None if pitch is None else partial(stripe_weighted_profile, blocks, region, pitch, channel)


def frame_rows_per_chip(profiles: Iterable[RowProfile], phy: PhyFormat) -> float | None:
    """One chip pitch (rows) for a frame: the median of its profiles' estimates.

    None when no profile gives one (:func:`profile_rows_per_chip`).
    """
    found = [p for p in (profile_rows_per_chip(profile, phy) for profile in profiles) if p is not None]
    return float(np.median(found)) if found else None


@dataclass(frozen=True)
class RegionView:
    """What the decoder saw in one LED region: for plots and debugging.

    Attributes
    ----------
    rows, cols : slice
        The region's frame rows and columns (bounding box).
    profile : RowProfile
    threshold : ndarray of float64 or None
        The binarisation threshold of each profile row (the midpoint of the
        local envelopes, DN); None when no chip pitch could be found.
    sdus : tuple of DecodedPhySdu
    stripe_rows : (int, int) or None
        First and last frame row where the decoder surely reads the LED's
        stripes (from the first to the last ON run that clearly reaches the
        ON level: where a whole PHY-SDU may lie; told the exposure, joined
        by the span of the chips sequence detection surely decides ON,
        always); None if nowhere.
    """

    rows: slice
    cols: slice
    profile: RowProfile
    threshold: np.ndarray | None
    sdus: tuple
    stripe_rows: tuple | None = None


def inspect_frame(
    image,
    phy: PhyFormat,
    clock_hz: float | None = None,
    row_time_s: float | None = None,
    frame_index: int = 0,
    *,
    block_px: int = 4,
    max_regions: int = 8,
    exposure_s: float | None = None,
) -> list[RegionView]:
    """Decode one frame and return, per LED region, what the decoder saw.

    Same parameters as :func:`decode_frame`; the PHY-SDUs are those it
    returns (failed ones included, truncated ones not). Told the exposure,
    it runs sequence detection on every region that holds a whole PHY-SDU
    for the stripe rows, even where decoding did not need it, so it costs
    more than :func:`decode_frame`.
    """
    options: dict[str, Any] = {"frame_index": frame_index, "include_failed": True, "include_truncated": False,
                               "min_contrast": MIN_CONTRAST_SIGMA, "exposure_rows": exposure_rows(exposure_s, row_time_s)}
    views = []
    for index, (cols, profile, pitch, weighted, found, found_weighted) in enumerate(_region_profiles(
            image, phy, clock_hz, row_time_s, block_px, max_regions, options["exposure_rows"])):
        # The stripe rows are measured on the rows the region tests found:
        # rows read beyond them for a PHY-SDU's ends change the profile's
        # local levels near its ends, not where the LED's stripes show. (The
        # measuring detection adds rows to the span only, never a PHY-SDU,
        # so it runs on the found rows alone.)
        sdus, levels, seen = _decode_profile_levels(profile, phy, pitch, region=index, weighted=weighted,
                                                    measure_span=found is profile, **options)
        if found is not profile:
            seen = _decode_profile_levels(found, phy, pitch, region=index, weighted=found_weighted,
                                          measure_span=True, **options)[2]
        rows = slice(profile.first_row, profile.first_row + len(profile))
        views.append(RegionView(rows, cols, profile, None if levels is None else levels.threshold, tuple(sdus), seen))
    return views


def stripe_row_fraction(image, phy: PhyFormat, clock_hz: float | None = None, row_time_s: float | None = None, *,
                        exposure_s: float | None = None) -> float:
    """Fraction of the frame's rows in which the decoder reads the LED's stripes.

    The union over LED regions of :attr:`RegionView.stripe_rows`, over the
    frame's height: the measured counterpart of the paper's ROI ratio
    (Fig. 11), which counts rows with readable stripes whether or not a
    whole PHY-SDU fits in them.

    Parameters
    ----------
    image : ndarray
        A frame, as :func:`decode_frame` takes it.
    phy, clock_hz, row_time_s, exposure_s
        As for :func:`decode_frame`. Told the exposure, the decoder's second
        look (sequence detection) may read stripes in rows thresholding
        does not, so the fraction may be larger.

    Returns
    -------
    float
        In [0, 1].
    """
    views = inspect_frame(image, phy, clock_hz, row_time_s, exposure_s=exposure_s)
    return views_stripe_fraction(views, np.asarray(image).shape[0])


def views_stripe_fraction(views: Iterable[RegionView], height: int) -> float:
    """:func:`stripe_row_fraction` of a frame ``height`` rows tall already inspected (``views``)."""
    if height == 0:
        return 0.0
    seen = np.zeros(height, dtype=bool)
    for view in views:
        if view.stripe_rows is not None:
            first, last = view.stripe_rows
            seen[max(first, 0) : min(last, height - 1) + 1] = True
    return float(seen.mean())


def decode_frames(
    frames: Iterable,
    phy: PhyFormat,
    clock_hz: float | None = None,
    row_time_s: float | None = None,
    *,
    first_frame: int = 0,
    errors: list | None = None,
    max_pixels: int = MAX_FRAME_PIXELS,
    **options,
) -> Iterator[FrameDecode]:
    """Decode a stream of frames, one :class:`FrameDecode` per frame.

    Parameters
    ----------
    frames : iterable of array_like or path
        Arrays, or PNG file names (read with :func:`decoder.io.read_frame`).
    phy, clock_hz, row_time_s
        As for :func:`decode_frame`.
    first_frame : int
        Index of the first frame. A file name ending in a number
        (``frame_000042.png``) gives its own index.
    errors : list, optional
        Error records (:meth:`FrameDecode.error_record`) of the frames that
        could not be decoded are appended here too.
    max_pixels : int, optional
        Largest frame file to read (:func:`decoder.io.read_frame`).
    **options
        Passed to :func:`decode_frame`.

    Yields
    ------
    FrameDecode
        A frame that cannot be read or is not a frame yields a result with
        ``error`` set (naming the file) and no PHY-SDU; decoding goes on.
    """
    for position, item in enumerate(frames):
        index = first_frame + position
        source = None
        if isinstance(item, (str, os.PathLike)):
            source = os.fspath(item)
            index = frame_index_from_name(source, index)
        try:
            image = read_frame(source, max_pixels) if source is not None else item
            sdus = decode_frame(image, phy, clock_hz, row_time_s, index, **options)
        except (FrameError, cv2.error) as exc:
            failed = FrameDecode(index, source, (), str(exc))
            if errors is not None:
                errors.append(failed.error_record())
            yield failed
            continue
        yield FrameDecode(index, source, tuple(sdus), None)
