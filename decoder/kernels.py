"""The decoder's compiled kernels, where numba is available; OpenCV or numpy otherwise.

**Block means.** The decoder's two largest passes over a frame are block
means: 4 × 4-pixel blocks for region detection
(:func:`decoder.region.block_means`) and 4-pixel column blocks of a
region's rows for its profile (:func:`decoder.profile.region_columns`).
OpenCV's ``INTER_AREA`` resize does both in about 0.7 ms per 1080p frame
each, one pixel at a time. On an 8-bit gray frame whose sides are multiples
of 4, a compiled loop reads four pixels as one 32-bit word and adds their
bytes two at a time inside it (each 16-bit lane of
``(x & 0x00FF00FF) + ((x >> 8) & 0x00FF00FF)`` holds the sum of two bytes,
at most 510, so four rows add up without carrying into the next lane):
about 0.1 ms for the blocks and 0.2 ms for a region spanning the frame.
The results are OpenCV's to the bit: ``INTER_AREA`` at an integer ratio
rounds an 8-bit mean half to even (``np.rint``), which the kernels do too.

**Noise power.** ``decoder.region._noise_power`` takes the smaller of two
squared differences per block, five numpy passes over the block image; the
kernel makes one, with the same float32 operations in the same order.

**Viterbi.** Sequence detection (``decoder.equalise.viterbi``) steps
through a profile's chips one at a time, for every grid (phase) and state.
On 20 frames of paper-default under ``decoder.inspect_frame`` (which runs
it on every region to measure the stripe rows), numpy's pass per chip took
17 ms a frame and the kernel takes 0.5 ms, with the same float64 sums and
comparisons in the same order.

Every kernel's result equals its fallback's bit for bit (tested). The
fallbacks run where numba is missing, where the project's switch
``ROLLSIM_JIT=0`` disables it, and for frames the fast path does not take
(colour, 16-bit, float, odd-sized or strided).

numba is imported the first time a kernel is asked for, so importing the
decoder costs nothing more. Each kernel depends on this file alone, which
numba's on-disk cache watches, so an edited kernel is compiled afresh.
"""

from __future__ import annotations

import os
from typing import Any, Callable

import numpy as np

# Pixels per block side of the fast path (one 32-bit word holds four 8-bit pixels).
WORD_PIXELS = 4
_DISABLED = ("0", "false", "no", "off")


def _block_means_words(words, n_block_rows):  # pragma: no cover - compiled
    """Means over 4 × 4 pixels of an 8-bit frame seen as 32-bit words (rows, W / 4), rounded half to even."""
    n_words = words.shape[1]
    out = np.empty((n_block_rows, n_words), np.float32)
    lanes = np.empty(n_words, np.uint32)
    mask = np.uint32(0x00FF00FF)
    for block_row in range(n_block_rows):
        lanes[:] = 0
        for row in range(WORD_PIXELS * block_row, WORD_PIXELS * block_row + WORD_PIXELS):
            line = words[row]
            for j in range(n_words):
                x = line[j]
                lanes[j] += (x & mask) + ((x >> np.uint32(8)) & mask)
        for j in range(n_words):
            total = (lanes[j] & np.uint32(0xFFFF)) + (lanes[j] >> np.uint32(16))
            out[block_row, j] = np.rint(np.float32(total) * np.float32(1.0 / 16.0))
    return out


def _column_means_words(words, first_row, stop_row, first_word, n_words):  # pragma: no cover - compiled
    """Means over 4 pixels along each row of an 8-bit frame seen as 32-bit words, rounded half to even."""
    out = np.empty((stop_row - first_row, n_words), np.float32)
    mask = np.uint32(0x00FF00FF)
    for i in range(stop_row - first_row):
        line = words[first_row + i]
        for j in range(n_words):
            x = line[first_word + j]
            pairs = (x & mask) + ((x >> np.uint32(8)) & mask)
            total = (pairs & np.uint32(0xFFFF)) + (pairs >> np.uint32(16))
            out[i, j] = np.rint(np.float32(total) * np.float32(0.25))
    return out


def _noise_power_rows(values, lag, bias, power):  # pragma: no cover - compiled
    """``decoder.region._noise_power``'s loop, into ``power`` (float32, like ``values``; more than 2·lag columns)."""
    rows, cols = values.shape
    half = np.float32(0.5)
    for r in range(rows):
        line = values[r]
        out = power[r]
        # Within a lag of either side, the one difference there is.
        for c in range(lag):
            d = line[c + lag] - line[c]
            out[c] = d * d * half
        for c in range(cols - lag, cols):
            d = line[c] - line[c - lag]
            out[c] = d * d * half
        # A select rather than min() (whose NaN rules it need not keep: the
        # squares are finite), so that the loop vectorises.
        for c in range(lag, cols - lag):
            d_left = line[c] - line[c - lag]
            d_right = line[c + lag] - line[c]
            left = d_left * d_left * half
            right = d_right * d_right * half
            out[c] = (left if left < right else right) / bias


def _viterbi_grids(metrics, top, chips, best):  # pragma: no cover - compiled
    """``decoder.equalise.viterbi``'s two passes, per grid, into ``chips`` (int8) and ``best`` (float64).

    ``top`` is the bit of a state that holds its newest chip.
    """
    n_grids, n_chips, n_combos = metrics.shape
    n_states = n_combos // 2
    mask = n_states - 1
    choice = np.empty((n_chips, n_states), np.int8)
    cost = np.empty(n_states)
    new = np.empty(n_states)
    for g in range(n_grids):
        cost[:] = 0.0
        for c in range(n_chips):
            row = metrics[g, c]
            # Combination b = 2·state' + (oldest chip); the state before it is b & mask.
            for s in range(n_states):
                stay = cost[(2 * s) & mask] + row[2 * s]
                leave = cost[(2 * s + 1) & mask] + row[2 * s + 1]
                take = leave < stay
                choice[c, s] = 1 if take else 0
                new[s] = leave if take else stay
            cost[:] = new
        state = 0
        for s in range(1, n_states):
            if cost[s] < cost[state]:
                state = s
        best[g] = cost[state]
        for c in range(n_chips - 1, -1, -1):
            chips[g, c] = (state >> top) & 1 if n_states > 1 else state
            state = (2 * state + choice[c, state]) & mask


_compiled: dict[str, Callable[..., Any]] | None = None
_checked = False


def _kernels() -> dict[str, Callable[..., Any]] | None:
    """The compiled kernels by name, or None (numba missing or disabled)."""
    global _compiled, _checked
    if os.environ.get("ROLLSIM_JIT", "1").strip().lower() in _DISABLED:
        return None
    if not _checked:
        _checked = True
        try:
            import numba
        except ImportError:  # OpenCV takes over
            return None
        compile_ = numba.njit(cache=True, nogil=True)
        _compiled = {"blocks": compile_(_block_means_words), "columns": compile_(_column_means_words),
                     "noise_power": compile_(_noise_power_rows), "viterbi": compile_(_viterbi_grids)}
    return _compiled


def frame_words(frame: np.ndarray, factor: int) -> np.ndarray | None:
    """The frame as rows of 32-bit words, if the fast path applies to it; else None.

    It applies to a C-contiguous 8-bit gray frame with blocks of
    :data:`WORD_PIXELS` and a height and width that are multiples of it,
    when the kernels are available.
    """
    if factor != WORD_PIXELS or frame.dtype != np.uint8 or frame.ndim != 2:
        return None
    # Otherwise OpenCV's blocks are not whole 4 × 4 pixels (it weighs the
    # pixels a block partly covers).
    if frame.shape[0] % WORD_PIXELS or frame.shape[1] % WORD_PIXELS:
        return None
    if not frame.flags.c_contiguous or _kernels() is None:
        return None
    return frame.view(np.uint32)


def block_means_u8(words: np.ndarray) -> np.ndarray:
    """Means over 4 × 4-pixel blocks (DN, rounded half to even) of a frame from :func:`frame_words`.

    Returns
    -------
    ndarray of float32, shape (H // 4, W // 4)
    """
    kernels = _kernels()
    assert kernels is not None, "frame_words returned words, so the kernels exist"
    return kernels["blocks"](words, words.shape[0] // WORD_PIXELS)


def column_means_u8(words: np.ndarray, rows: slice, block_cols: slice) -> np.ndarray:
    """Means over 4-pixel column blocks (DN, rounded half to even) of some rows of a frame from :func:`frame_words`.

    Parameters
    ----------
    words : ndarray of uint32, shape (H, W / 4)
    rows : slice
        Frame rows [start, stop).
    block_cols : slice
        Column blocks [start, stop) (pixels 4·start to 4·stop).

    Returns
    -------
    ndarray of float32, shape (rows, block columns)
    """
    kernels = _kernels()
    assert kernels is not None, "frame_words returned words, so the kernels exist"
    return kernels["columns"](words, rows.start, rows.stop, block_cols.start, block_cols.stop - block_cols.start)


def noise_power_f32(values: np.ndarray, lag: int, bias: float) -> np.ndarray | None:
    """``decoder.region._noise_power`` of a float32 image with sides wider than two lags; None without the kernels."""
    kernels = _kernels()
    if kernels is None or values.dtype != np.float32 or values.ndim != 2 or values.shape[1] <= 2 * lag:
        return None
    power = np.empty_like(values)
    kernels["noise_power"](values, lag, np.float32(bias), power)
    return power


def viterbi_f64(metrics: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``decoder.equalise.viterbi`` of C-contiguous float64 metrics (G, n_chips, 2^L); None without the kernels.

    The same sums and comparisons in the same order, so the chips and
    costs equal the numpy pass's to the bit.
    """
    kernels = _kernels()
    if kernels is None or metrics.dtype != np.float64 or metrics.ndim != 3 or not metrics.flags.c_contiguous:
        return None
    chips = np.zeros(metrics.shape[:2], dtype=np.int8)
    best = np.empty(metrics.shape[0])
    top = max((metrics.shape[2] // 2).bit_length() - 2, 0)
    kernels["viterbi"](metrics, top, chips, best)
    return chips, best

