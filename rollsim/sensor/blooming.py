"""Blooming: charge above full well spills along the column.

A pixel holding q > C (C the full well) keeps C; a fraction s of its excess
q − C (``spill_fraction``) leaves half upwards and half downwards along its
column, and the rest goes to the pixel's anti-blooming drain (s = 1: no
drain, the worst case). Each half fills the room
C − q' of the pixels it passes, in order, until it is used up or leaves the
frame at the top or bottom edge. Spilled charge is conserved: what the
column holds after, plus what left the frame (and what drained), is what it
held before.

The downward pass is the queue recursion out_i = max(0, out_{i−1} + x_i),
x_i = (own excess going down) − (room), whose closed form
out_i = S_i − min(0, min_{j≤i} S_j) with S the cumulative sum of x makes it
a few vectorised passes over the columns; pixel i absorbs
out_{i−1} + x_i + room_i − out_i. The upward pass is the same recursion on
the reversed column, over the room the downward pass left. Where the two
flows compete for the room of the same pixels, the downward flow fills first
(a convention: the model has no time order inside the exposure). Only
columns with an over-full pixel are touched.

Where numba runs, one compiled loop does both passes on a float32 frame
with the same operations in the same order (numpy's running sum adds row
after row), so the bytes are the numpy twin's.
"""

from __future__ import annotations

import numpy as np

from rollsim.numerics.jit import kernel
from rollsim.plumbing.validation import as_positive, as_probability


def _spill_down(charge: np.ndarray, spill: np.ndarray, full_well_e: float) -> np.ndarray:
    """Fill the room below each pixel with ``spill``; returns the charge left over at the bottom.

    ``charge`` (rows, columns) is updated in place; every pixel is ≤ full well.
    """
    total = spill + charge
    total -= full_well_e  # x = spill − room
    np.cumsum(total, axis=0, out=total)
    low = np.minimum.accumulate(total, axis=0)
    np.minimum(low, 0.0, out=low)
    out = np.subtract(total, low, out=total)
    # Pixel i absorbs out_{i−1} + spill_i − out_i.
    charge += spill
    charge -= out
    charge[1:] += out[:-1]
    # Rounding of the running sums can leave ±1e-9 e⁻; the clip keeps the bound.
    np.clip(charge, 0.0, full_well_e, out=charge)
    return out[-1].copy()


# Columns of span the compiled pass takes on per over-full column before the numpy twin is cheaper.
SPAN_PER_COLUMN = 12


@kernel
def _bloom_kernel(electrons, first_col, stop_col, half_scale, full_well, charge, lost):
    # bloom's numpy steps on the columns first_col … stop_col − 1 of the
    # frame, in place: the spill (half_scale · max(q − C, 0)) recomputed
    # from the frame as each pass needs it, both passes of _spill_down
    # (down, then up over what the first left, writing the frame back), row
    # after row with the columns inside so that LLVM vectorises the loop
    # over a row. The same IEEE operations in the same order as the numpy
    # twin's (numpy's running sum adds row after row; np.minimum, np.maximum
    # and np.clip compare as written here). A column of the span with no
    # over-full pixel spills nothing and comes out as it went in, so the
    # span's bytes are those of the over-full columns alone.
    rows = electrons.shape[0]
    cols = stop_col - first_col
    running = np.empty(cols, dtype=np.float64)
    lowest = np.empty(cols, dtype=np.float64)
    previous = np.empty(cols, dtype=np.float64)
    for direction in range(2):
        for step in range(rows):
            i = step if direction == 0 else rows - 1 - step
            frame = electrons[i, first_col:stop_col]
            row = charge[i]
            for k in range(cols):
                q = np.float64(frame[k])
                excess = q - full_well
                spill = half_scale * (excess if excess >= 0.0 else 0.0)
                held = (q if q <= full_well else full_well) if direction == 0 else row[k]
                x = (spill + held) - full_well
                total = x if step == 0 else running[k] + x
                low = total if step == 0 else (lowest[k] if lowest[k] <= total else total)
                out = total - (low if low <= 0.0 else 0.0)
                c = (held + spill) - out
                if step > 0:
                    c = c + previous[k]
                c = c if c > 0.0 else 0.0
                c = c if c < full_well else full_well
                row[k] = c
                if direction == 1:
                    frame[k] = np.float32(c)
                running[k] = total
                lowest[k] = low
                previous[k] = out
        for k in range(cols):
            lost[direction, k] = previous[k]
    return 0


def bloom(electrons: np.ndarray, full_well_e: float, spill_fraction: float = 1.0) -> float:
    """Spill the charge above ``full_well_e`` along columns, in place.

    Parameters
    ----------
    electrons : ndarray, shape (rows, columns)
        Charge per pixel in e⁻ (any float dtype); updated in place.
    full_well_e : float
        Full-well capacity C in e⁻.
    spill_fraction : float
        Fraction of the excess that spills, in [0, 1]; the rest drains away.

    Returns
    -------
    float
        Spilled charge that left the frame at the top and bottom edges, in e⁻.
    """
    as_positive(full_well_e, "full_well_e")
    as_probability(spill_fraction, "spill_fraction")
    columns = np.flatnonzero((electrons > full_well_e).any(axis=0))
    if columns.size == 0:
        return 0.0
    first, stop = int(columns[0]), int(columns[-1]) + 1
    compiled = _bloom_kernel.compiled
    # The kernel works on the span of columns from the first over-full one to
    # the last, at ~1/13 of the numpy twin's cost per column (measured at
    # 1080 rows): the twin wins where a few over-full columns lie far apart.
    if (compiled is not None and electrons.flags.c_contiguous and electrons.dtype == np.float32
            and SPAN_PER_COLUMN * columns.size >= stop - first):
        leaving = np.empty((2, stop - first))
        compiled(electrons, first, stop, 0.5 * spill_fraction, float(full_well_e),
                 np.empty((electrons.shape[0], stop - first)), leaving)
        return float((leaving[0] + leaving[1])[columns - first].sum())
    charge = electrons[:, columns].astype(np.float64)
    half = (0.5 * spill_fraction) * np.maximum(charge - full_well_e, 0.0)
    np.minimum(charge, full_well_e, out=charge)
    lost = _spill_down(charge, half, full_well_e)
    lost = lost + _spill_down(charge[::-1], half[::-1], full_well_e)
    electrons[:, columns] = charge
    return float(lost.sum())
