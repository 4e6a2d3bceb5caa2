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
"""

from __future__ import annotations

import numpy as np

from rollsim.validation import as_positive, as_probability


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
    charge = electrons[:, columns].astype(np.float64)
    half = (0.5 * spill_fraction) * np.maximum(charge - full_well_e, 0.0)
    np.minimum(charge, full_well_e, out=charge)
    lost = _spill_down(charge, half, full_well_e)
    lost = lost + _spill_down(charge[::-1], half[::-1], full_well_e)
    electrons[:, columns] = charge
    return float(lost.sum())
