"""Binned readout seen in a frame's rows: groups of k near-identical rows.

A sensor that bins k rows reads them as one and writes the value to all k,
so the rows come in groups: neighbours within a group differ by nothing (or
by the little an ISP adds), neighbours across a group's edge by the signal.
A group's rows share one exposure start, so a stripe's edges can fall only
between groups, and a period shorter than :data:`MIN_GROUPS_PER_PERIOD`
groups cannot be measured: it aliases.
"""

from __future__ import annotations

import numpy as np

# Rows in groups of k are binned when neighbours within a group differ at
# most this fraction as much as neighbours across a group's edge (a
# JPEG's 8-row blocks and 4:2:0 chroma pairs stay above it).
BINNED_RATIO = 0.1
MAX_BINNING = 4
# Ratios closer than this are a tie, won by the larger k.
TIE_RATIO = 0.02
# Groups a stripe period must span to be measured: above the sampling
# theorem's 2, with the margin an exposure box and noise ask.
MIN_GROUPS_PER_PERIOD = 2.5


def binned_groups(steps: np.ndarray) -> tuple[int, int]:
    """Binning (k, offset) from the rows' mean absolute steps; rows ``offset + j·k`` start each group.

    Parameters
    ----------
    steps : ndarray, shape (n - 1,)
        Mean absolute difference of row r + 1 and row r (over columns, or
        frames and columns), r = 0 … n − 2.

    Returns
    -------
    (k, offset)
        (1, 0) when the rows are not grouped. For each k (2 …
        :data:`MAX_BINNING`) and offset, the mean step within groups is set
        against that across group edges; the k with the lowest ratio is
        taken when that is under :data:`BINNED_RATIO`, the larger k on a tie
        (:data:`TIE_RATIO`).
    """
    steps = np.asarray(steps, dtype=np.float64)
    best, best_ratio = (1, 0), 1.0
    boundary = np.arange(1, steps.size + 1)  # steps[i] compares rows i and i + 1
    # The largest k first, and a smaller one only if clearly better: rows
    # binned by 4 are in identical pairs too.
    for k in range(MAX_BINNING, 1, -1):
        if steps.size + 1 < 4 * k:
            continue
        for offset in range(k):
            across = (boundary - offset) % k == 0
            if not across.any() or across.all():
                continue
            inside, edge = float(steps[~across].mean()), float(steps[across].mean())
            ratio = inside / edge if edge > 0 else 1.0
            if ratio < BINNED_RATIO and (best == (1, 0) or ratio < best_ratio - TIE_RATIO):
                best, best_ratio = (k, offset), ratio
    return best


def profile_binning(values: np.ndarray) -> int:
    """Rows per binned group in a row profile (1 when its rows are not grouped)."""
    return binned_groups(np.abs(np.diff(np.asarray(values, dtype=np.float64))))[0]
