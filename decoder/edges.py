"""Where a thresholded profile surely shows the LED: the rows a whole PHY-SDU may lie in.

Past the LED's last row the background is binarised too, and an OFF chip
looks like the background, so a PHY-SDU is taken as whole only inside the
LED's span: from its first to its last ON run that clearly reaches the ON
level (:func:`led_edges`). A PHY-SDU that ends in OFF chips on the LED's
last rows would be cut off by that rule alone. Two kinds of evidence carry
the span over such a final OFF run:

* a rising edge closes it into an ON run (the next SYNC, cut too short by
  the footprint's edge to be confident), the run being a whole number of
  chips;
* a level step ends it (:func:`last_face_row`): the LED's face differs
  from what surrounds it (paper-geometric's face reads about 25 DN
  against a 60 DN wall), so its last OFF rows lie on the OFF level's side
  of the flat background that follows, several noise sigmas off it. The
  final chip counts as seen where the face shows over half of it. On
  paper-geometric with CRC-8, 3 of 750 fully visible PHY-SDUs (300
  frames) end in an OFF chip on row 1070 of a disk ending on row 1072;
  this reads them.

The measured stripe rows (the ROI ratio's) do not take the rows a step adds:
a lone OFF chip is no stripe, and the emitter was fitted to them.

Where the face matches the background nothing in one frame shows where its
OFF chips end, and the span stays at the last ON run. Carrying the span over
OFF rows cannot turn a read wrong unseen: the rows are read as OFF chips,
and reading an ON chip as OFF breaks the balanced line codes (every
Manchester pair and every 4B6B word holds a fixed count of ON chips).
"""

from __future__ import annotations

import numpy as np

from decoder.binarize import Binarized, confident_on_span
from decoder.order_stats import median, percentiles
from decoder.timing import Runs

# An edge run longer or shorter than a whole number of chips by more than
# this (chips) is taken as cut by the footprint's edge.
CUT_RUN_OFF_GRID_CHIPS = 0.2
# Tolerance (rows) of the LED's row span (see timing.CUT_TOLERANCE_ROWS).
SPAN_TOLERANCE_ROWS = 0.5
# A row lies off the background's level when it differs from the
# background's median by this many noise sigmas (of the difference). Over
# the few rows of a final OFF run, Gaussian noise passes 4 sigma with a
# probability of about 6e-5 per row.
STEP_SIGMAS = 4.0
# Least rows of flat background that show the LED has ended.
MIN_WALL_ROWS = 3
# Chips before a final OFF run whose lowest rows give the LED's OFF level.
OFF_LEVEL_CHIPS = 8


def last_face_row(values: np.ndarray, noise: np.ndarray, start: int, rows_per_chip: float) -> int | None:
    """The last row of a final OFF run that still shows the LED's face against a flat background.

    The profile's last ``max(3, ⌈rows_per_chip⌉)`` rows give the
    background's level (their median); the LED's OFF level is the 5th
    percentile of the :data:`OFF_LEVEL_CHIPS` chips before the run (the
    lower envelope, taken before the run as a background darker than the
    face would pull a window reaching past it down). Going back from the profile's end,
    the rows within :data:`STEP_SIGMAS` sigmas of it are background. The
    step counts when that background lies clearly off the OFF level and
    holds at least a chip of rows (a chip-long flat stretch at a level that
    is neither ON nor OFF holds no chips), and a row within the chip before
    it lies on the OFF level's side of it by :data:`STEP_SIGMAS` sigmas:
    the LED's face, seen there. Rows between (the footprint's partly
    covered edge, the next chip smeared in by the exposure) show neither.

    Parameters
    ----------
    values, noise : ndarray, shape (n,)
        The row profile and each row's noise sigma (same units).
    start : int
        First row of the final OFF run (no ON row follows it).
    rows_per_chip : float
        Chip pitch, rows.

    Returns
    -------
    int or None
        The last row showing the face; None where no such step shows.
    """
    n = values.size
    chip_rows = int(np.ceil(rows_per_chip))
    wall_rows = max(MIN_WALL_ROWS, chip_rows)
    before = int(np.ceil(OFF_LEVEL_CHIPS * rows_per_chip))
    if start < before or n - start <= wall_rows:
        return None
    off_level = percentiles(values[start - before:start], (5.0,))[0]
    wall = median(values[n - wall_rows:])
    # The difference's noise: one row's and the median's (pi/2 times a
    # mean's variance).
    band = STEP_SIGMAS * median(noise[start:]) * np.sqrt(1.0 + 0.5 * np.pi / wall_rows)
    side = np.sign(off_level - wall)
    if abs(off_level - wall) <= band:
        return None
    off_wall = np.flatnonzero(np.abs(values[start:] - wall) > band)
    if off_wall.size == 0:
        return None
    background = start + int(off_wall[-1]) + 1
    if n - background < wall_rows:
        return None
    near = max(start, background - chip_rows)
    face = np.flatnonzero(side * (values[near:background] - wall) > band)
    return near + int(face[-1]) if face.size else None


def led_edges(runs: Runs, levels: Binarized, pitch: float, values: np.ndarray, noise: np.ndarray):
    """Where the LED is surely seen, and which runs its edges may cut.

    The span runs from the first to the last ON run that clearly reaches the
    ON level (:func:`decoder.binarize.confident_on_span`), and on over the
    final OFF run that a rising edge or a level step closes (see the module's
    text); rows outside may be background read as bits. The first and last
    of these ON runs may be cut by the footprint's edge although they look
    whole: one that is not a whole number of chips long is treated as cut,
    so its chips are laid from its inner edge.

    Parameters
    ----------
    runs : Runs
    levels : Binarized
        The levels the runs were found in.
    pitch : float
        Chip pitch, rows.
    values, noise : ndarray, shape (n,)
        The row profile that was binarised, and each row's noise sigma.

    Returns
    -------
    (cut_left, cut_right, span, striped) or None
        Boolean arrays over runs; the (first, last) row a whole PHY-SDU
        must lie in (profile coordinates); and the same without the rows a
        level step adds, where the LED's stripes are surely seen (the
        measured stripe rows, to which the emitter was fitted: a lone OFF
        chip at the LED's end is no stripe). None if the LED is never
        clearly ON.
    """
    seen = confident_on_span(levels.level, levels.q)
    if seen is None:
        return None
    first_on = np.searchsorted(runs.bounds, seen[0], side="right") - 1
    last_on = np.searchsorted(runs.bounds, seen[1], side="right") - 1
    on_runs = np.flatnonzero(runs.values == 1)
    on_runs = on_runs[(on_runs >= first_on) & (on_runs <= last_on)]
    if on_runs.size == 0:
        return None
    first, last = on_runs[0], on_runs[-1]
    chips = runs.lengths / pitch
    off_grid = np.abs(chips - np.rint(chips)) > CUT_RUN_OFF_GRID_CHIPS
    cut_left = np.zeros(runs.values.size, dtype=bool)
    cut_right = np.zeros(runs.values.size, dtype=bool)
    cut_left[first] = off_grid[first]
    cut_right[last] = off_grid[last]
    end_row = runs.bounds[last + 1]
    following = runs.values[last + 1:]
    if following.size > 1 and following[0] == 0 and following[1] == 1 and not off_grid[last + 1]:
        # A PHY-SDU ending in OFF chips ends at the rising edge of the next
        # SYNC, whose ON run the footprint's edge may cut too short to be
        # confident.
        end_row = runs.bounds[last + 2]
    striped = (runs.bounds[first] - SPAN_TOLERANCE_ROWS, end_row + SPAN_TOLERANCE_ROWS)
    if following.size and following[0] == 0 and not np.any(following == 1):
        face = last_face_row(values, noise, int(np.ceil(runs.bounds[last + 1])), pitch)
        if face is not None:
            # The final chip counts as seen if the face shows over at least
            # half of it.
            end_row = max(end_row, face + 0.5 + 0.5 * pitch)
    span = (striped[0], end_row + SPAN_TOLERANCE_ROWS)
    return cut_left, cut_right, span, striped
