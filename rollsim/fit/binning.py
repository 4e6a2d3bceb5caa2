"""Binned readout seen in a camera's frames: rows read out in groups of k.

A binned sensor writes one value for each group of k rows, so neighbouring
rows within a group are identical before the camera's processing, and
:func:`decoder.binning.binned_groups` finds groups whose rows differ at most a
tenth as much as rows across groups. The camera's processing blurs that:
JPEG's quantisation error differs from row to row, demosaicing and the ISP's
smoothing mix neighbouring rows. The groups still show, as an order: the
step from a row to the next within a group is smaller than the step across
the next group edge in nearly every pair of the two (:func:`paired_steps`),
where frames without binning make it smaller about half the time. JPEG
codes blocks of 8 rows, so a step across a block edge is larger whatever the
binning: those steps are left out; and its error differs from place to place
in a block, which orders some pairs whatever the binning, so the order must
hold at every place (a binned sensor's does). Colour frames are read on their
luminance: JPEG subsamples the chroma over pairs of rows (4:2:0), which
gives the red and blue planes an order of its own.

Measured on the hidden cameras of ``rollsim bench fit-camera`` (seeds 1–3,
120 cameras, six frames each, grey or luminance): among the 48 without
binning, the smaller step lies within a pair of rows in at most 0.71 of
the pairs at some place (JPEG), and none is read as binned; of the 72
binned, 51 are found (23 by identical groups alone), JPEG of quality
60–100 and smoothing up to 1.5 rows included. The 21 missed mostly join
JPEG under quality 90 or smoothing over 0.5 rows (fractions 0.13–0.89),
which mix the pairs' rows. Rendered 480×360 frames without binning,
through JPEG 60 and a row of smoothing, reach 0.78–0.84
(``tests/test_fit_binning.py``). One unbinned camera of seed 7 is read as
binned: 3801×2138 colour on a black background, its LED spanning 3.6
stripe periods (not counted by the benchmark), every one of its 801 pairs
ordered: the background's steps (0.03–0.3 levels) come from the few pixels
off the black clip, which JPEG's chroma, shared by pairs of rows (4:2:0),
orders where no stripe dominates them. Steps taken only between pixels off
the clip order 0.75 of its pairs, but leaving clipped pixels out loses
binned cameras whose informative edges clip (a saturated LED's: seed 2
camera 30, seed 5 camera 30, seed 7 camera 35), so they are kept.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from decoder.binning import binned_groups
from rollsim.fit.stripes import StripeFit, fit_stripes

# Pairs of steps in which the step within a group must be the smaller, and
# the fewest decided pairs that can tell (at 0.5 for unbinned rows, the
# standard error of the fraction over 60 pairs is 0.065).
PAIRED_FRACTION = 0.9
MIN_PAIRS = 60
# JPEG codes blocks of this many rows.
JPEG_BLOCK_ROWS = 8
# The stripe model with pairs of rows read as one is kept where its RMS
# residual is at most this fraction of the unbinned model's
# (:func:`binned_if_nearer`). Measured on the hidden cameras of
# ``rollsim bench fit-camera`` seeds 1 and 2 whose row time is read (33,
# six frames, grey or luminance): the 16 without binning give 0.986 at the
# least (long exposures and smoothing, where a staircase of two rows and a
# ramp look alike) and up to 56; the 6 binned ones the order statistic
# misses 0.52 to 1.8 (seed 6 camera 24: 0.12).
BINNED_RESIDUAL_RATIO = 0.8


def row_steps(frames: Sequence[np.ndarray]) -> np.ndarray:
    """Mean absolute step from each row to the next, over frames and columns (8-bit levels), shape (H − 1,)."""
    stack = np.asarray(frames, dtype=np.float64)
    return np.abs(np.diff(stack, axis=1)).mean(axis=(0, 2))


def paired_steps(steps: np.ndarray) -> tuple[float, int, int]:
    """How often the step within a pair of rows is smaller than the step after it.

    For each offset o (0 or 1), the steps are taken in pairs (step o + 2j,
    step o + 2j + 1): within a group of two rows starting at row o + 2j,
    and across its edge. Pairs with a step across a JPEG block edge
    (:data:`JPEG_BLOCK_ROWS`) and ties (flat or clipped rows) are left out.

    Parameters
    ----------
    steps : ndarray, shape (n,)
        :func:`row_steps`: steps[i] compares rows i and i + 1.

    Returns
    -------
    (fraction, offset, pairs)
        For the offset where the step within is the smaller most often:
        that fraction of the decided pairs (the least over the places in a
        JPEG block the pairs start at), the offset, and how many pairs were
        decided ((0.5, 0, 0) when none).
    """
    steps = np.asarray(steps, dtype=np.float64)
    found = []
    for offset in (0, 1):
        within = np.arange(offset, steps.size - 1, 2)
        across = within + 1
        clear = ((within % JPEG_BLOCK_ROWS) != JPEG_BLOCK_ROWS - 1) & ((across % JPEG_BLOCK_ROWS) != JPEG_BLOCK_ROWS - 1)
        within, across = within[clear], across[clear]
        decided = steps[within] != steps[across]
        n = int(np.count_nonzero(decided))
        if n == 0:
            continue
        smaller = steps[within] < steps[across]
        # Each place in a JPEG block on its own: the codec's error differs
        # from place to place, which orders some pairs of steps whatever the
        # binning; a binned sensor orders them at every place.
        places = (within % JPEG_BLOCK_ROWS)[decided]
        ordered = smaller[decided]
        found.append((min(float(np.mean(ordered[places == p])) for p in np.unique(places)), offset, n))
    return max(found, key=lambda f: f[0]) if found else (0.5, 0, 0)


def detect_binning(frames: Sequence[np.ndarray]) -> tuple[int, int]:
    """Binned readout seen in the frames: (k, offset), rows ``offset + j·k``
    starting each group of k; (1, 0) when the rows are not grouped.

    Groups of near-identical rows first (:func:`decoder.binning.binned_groups`,
    any k up to 4); then, for processed frames whose groups are no longer
    identical, pairs of rows whose inner step is the smaller in at least
    :data:`PAIRED_FRACTION` of :data:`MIN_PAIRS` or more decided pairs
    (:func:`paired_steps`).

    Parameters
    ----------
    frames : sequence of ndarray
        Grey frames (H, W), 8-bit levels as float; colour frames' luminance.
    """
    steps = row_steps(frames)
    found = binned_groups(steps)
    if found != (1, 0):
        return found
    fraction, offset, pairs = paired_steps(steps)
    if pairs >= MIN_PAIRS and fraction >= PAIRED_FRACTION:
        return 2, offset
    return 1, 0


def binned_if_nearer(stripes: StripeFit, profiles: list[np.ndarray], rows: np.ndarray,
                     period_rows: float) -> tuple[StripeFit, tuple[int, int], float]:
    """The stripe fit with pairs of rows read as one, where the stripes' own shape asks for it.

    JPEG and the ISP's smoothing can hide a binned sensor's pairs from
    :func:`detect_binning`, but not its timing: each pair is exposed over
    one interval, so the stripes' edges come as steps of two rows. The
    stripe model read with binning (2, offset), started from the unbinned
    fit ``stripes`` (:func:`rollsim.fit.stripes.fit_stripes`), is kept where its RMS
    residual is at most :data:`BINNED_RESIDUAL_RATIO` of the unbinned one's.

    Parameters
    ----------
    stripes : StripeFit
        The unbinned model's fit of ``profiles``.
    profiles, rows, period_rows
        As :func:`rollsim.fit.stripes.fit_stripes`.

    Returns
    -------
    (StripeFit, (k, offset), float)
        ``stripes`` and (1, 0), or the binned fit and (2, offset); and the
        least binned residual over the unbinned one (how far the edges are
        from steps of two rows: :mod:`rollsim.fit.binned_trial` reads it).
    """
    best, binning = stripes, (1, 0)
    fits = offset_fits(stripes, profiles, rows, period_rows, 2, (0, 1))
    for offset, trial in fits:
        if trial.rms_residual <= BINNED_RESIDUAL_RATIO * stripes.rms_residual and \
                trial.rms_residual < best.rms_residual:
            best, binning = trial, (2, offset)
    least = min(trial.rms_residual for _, trial in fits)
    # An exact unbinned fit (noise-free model frames) leaves no residual to divide by.
    ratio = least / stripes.rms_residual if stripes.rms_residual > 0 else (1.0 if least == 0 else math.inf)
    return best, binning, ratio


def offset_fits(stripes: StripeFit, profiles: list[np.ndarray], rows: np.ndarray, period_rows: float,
                k: int, offsets: Sequence[int]) -> list[tuple[int, StripeFit]]:
    """The stripe model read with groups of ``k`` rows from each first row
    in ``offsets``, each started from ``stripes``; ``[(offset, fit), …]``."""
    return [(offset, fit_stripes(profiles, rows, period_rows, start=stripes, binning=(k, offset)))
            for offset in offsets]


def nearest_offset(stripes: StripeFit, profiles: list[np.ndarray], rows: np.ndarray, period_rows: float,
                   k: int) -> tuple[StripeFit, tuple[int, int]]:
    """Binning of ``k`` rows known (:class:`rollsim.fit.camera.Known`), its groups'
    first row not: groups from row 0, as the fitted scene renders them, unless
    another offset's stripe fit leaves at most :data:`BINNED_RESIDUAL_RATIO`
    of its RMS residual (the staircase's misfit, as :func:`binned_if_nearer`
    reads it). Where JPEG and smoothing round the staircase, the offsets'
    fits differ by their noise, and the least residual would pick either.

    Parameters
    ----------
    stripes : StripeFit
        The stripes' fit with groups of ``k`` from row 0 (kept, or the start of the others).
    profiles, rows, period_rows
        As :func:`rollsim.fit.stripes.fit_stripes`.
    k : int
        Rows in a group.

    Returns
    -------
    (StripeFit, (k, offset))
    """
    if k == 1:
        return stripes, (1, 0)
    fits = offset_fits(stripes, profiles, rows, period_rows, k, range(1, k))
    offset, fit = min(fits, key=lambda f: f[1].rms_residual)
    if fit.rms_residual > BINNED_RESIDUAL_RATIO * stripes.rms_residual:
        return stripes, (k, 0)
    return fit, (k, offset)
