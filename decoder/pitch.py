"""Chip pitch (rows per chip) of a profile whose row time is not known.

Every ON/OFF edge of a rolling-shutter profile lies on a grid of one chip
pitch P: a rising (falling) edge sits at a + P·k for an integer chip index k.
The exposure smears chips into their neighbours, which moves each edge by an
amount that depends on the chips around it (intersymbol interference), and
saturation or blooming move every rising edge one way and every falling
edge the other; but neither moves the grid. So P is estimated in two steps:

1. candidates from the spectrum of the profile's edge energy (the squared
   row-to-row difference), whose lines lie at harmonics of the code
   symbol's rate (two chips for Manchester, six for 4B6B): every pitch that
   puts a harmonic at the strongest line;
2. for each candidate, from the longest down, a regression over the edges
   (:func:`edge_grid_fit`) with one intercept for the rising and one for the
   falling edges. A candidate twice the true pitch leaves half the edges
   half-way between grid lines; the longest candidate whose edges sit on the
   grid is the pitch. (Half the true pitch fits too, which is why the
   longest is taken.)

Run lengths alone (:func:`decoder.timing.estimate_rows_per_chip`) need the
runs binarised with a window suited to the pitch, which is what is not yet
known: a long exposure, saturation or an ISP's vertical smoothing spread a
single chip's run from 0.7 to 1.4 chips, and the least-squares fit of the
run lengths then converges on two-thirds or four-thirds of the pitch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from decoder.timing import MIN_ROWS_PER_CHIP, Runs

# Largest RMS distance of the edges from their grid, as a fraction of the
# pitch, for the grid to be the chips'. Intersymbol interference moves an
# edge by up to ~0.18 chip at 3 rows per chip and an exposure of about a
# chip (measured on paper-default at 12 kHz).
MAX_GRID_RESIDUAL = 0.25
# The edges lie as close (in rows) to the true grid as to any grid finer
# than it, which may absorb some of their jitter and the odd stray edge
# half a chip off; on a grid that is a multiple of the pitch a third or more
# of them lie far off it (Manchester's rising edges fall on odd and even
# chips). So a grid is the chips' when SPREAD_QUANTILE of its edges lie
# within GRID_RESIDUAL_FACTOR times the least such distance among the
# candidates (or within GRID_FLOOR_ROWS); the quantile leaves a few stray
# edges out, but not a third.
SPREAD_QUANTILE = 0.8
GRID_RESIDUAL_FACTOR = 3.0
GRID_FLOOR_ROWS = 0.1
# A grid fit may move its candidate by less than this (relative) and still
# be that candidate's: further, it has slipped to another grid.
MAX_GRID_SHIFT = 0.25
# Harmonics of the chip rate that may be the edge energy's strongest line:
# saturated edges are sharp, and their harmonics can outshine the chip rate.
MAX_MULTIPLE = 6
# Refits of the grid with every edge counted from the last fit, and the
# distance (chips) beyond which an edge is left out of the next.
GRID_PASSES = 3
OUTLIER_CHIPS = 0.25
# Fewest edges (rising and falling together) for a grid fit.
MIN_GRID_EDGES = 8
# Candidates closer than this (relative) are one (harmonics k and k + 1 of
# the symbol rate differ by more, up to k = 36).
SAME_CANDIDATE = 0.02


@dataclass(frozen=True)
class GridFit:
    """The chip grid fitted to a profile's edges.

    Attributes
    ----------
    rows_per_chip : float
        Pitch of the grid, rows.
    stderr_rows : float
        Its standard error, rows.
    residual : float
        RMS distance of the edges from the grid, as a fraction of the pitch.
    spread_rows : float
        The distance from the grid (rows) that :data:`SPREAD_QUANTILE` of
        the edges lie within.
    n_edges : int
    """

    rows_per_chip: float
    stderr_rows: float
    residual: float
    spread_rows: float
    n_edges: int


def peak_period_rows(signal: np.ndarray, min_rows: float, max_rows: float) -> float | None:
    """Period (rows) of the strongest line in a signal's spectrum.

    Hann-windowed, zero-padded eightfold, with parabolic interpolation of the
    log magnitude around the peak.

    Parameters
    ----------
    signal : ndarray, shape (n,) or (m, n)
        One signal, or m signals along the same rows whose power spectra
        are added (lines common to them add whatever their phases).
    min_rows, max_rows : float
        The band searched, as periods in rows.

    Returns
    -------
    float or None
        None when the band holds fewer than three frequency bins.
    """
    signals = np.atleast_2d(np.asarray(signal, dtype=np.float64))
    n = signals.shape[1]
    if n < 4:
        return None
    size = 1 << int(np.ceil(np.log2(8 * n)))
    transforms = np.fft.rfft((signals - signals.mean(axis=1, keepdims=True)) * np.hanning(n), size, axis=1)
    spectrum = np.abs(transforms[0]) if len(signals) == 1 else np.sqrt(np.sum(np.abs(transforms) ** 2, axis=0))
    freqs = np.fft.rfftfreq(size)
    band = (freqs >= 1.0 / max_rows) & (freqs <= 1.0 / min_rows)
    if band.sum() < 3:
        return None
    k = int(np.flatnonzero(band)[np.argmax(spectrum[band])])
    if k <= 0 or k >= spectrum.size - 1:
        return float(1.0 / freqs[k])
    a, b, c = np.log(spectrum[k - 1 : k + 2] + 1e-300)
    denom = a - 2.0 * b + c
    shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
    return float(1.0 / ((k + float(np.clip(shift, -0.5, 0.5))) * (freqs[1] - freqs[0])))


def edge_energy_period_rows(values: np.ndarray) -> float | None:
    """Period (rows) of the strongest line of a profile's edge energy.

    The edge energy (the squared row-to-row difference) is cyclostationary
    with the period of a code symbol: its lines lie at harmonics of the
    symbol rate, the chip rate among them. Rising and falling edges are
    taken apart and their power spectra added: saturation moves every
    rising edge one way and every falling edge the other, by an amount that
    changes with the row's brightness, and in one sequence the two grids'
    lines would interfere (on paper-default at 5 cm, whose core saturates,
    the strongest line of the joint energy lay at 7.9 rows, the pitch being
    4.5); each polarity alone lies on the chip grid.

    Returns
    -------
    float or None
        None for a profile too short to hold four periods of the least pitch.
    """
    values = np.asarray(values, dtype=np.float64)
    max_rows = values.size / 4.0
    if max_rows <= 2.0 * MIN_ROWS_PER_CHIP:
        return None
    steps = np.diff(values)
    return peak_period_rows(np.stack([np.maximum(steps, 0.0) ** 2, np.minimum(steps, 0.0) ** 2]),
                            MIN_ROWS_PER_CHIP, max_rows)


def pitch_candidates(period_rows: float, symbol_chips: int, max_rows: float) -> list[float]:
    """Chip pitches (rows) whose symbol rate has a harmonic at ``period_rows``.

    A line at period P is the k-th harmonic of the symbol rate for some k,
    so the pitch is k·P / ``symbol_chips``; k runs up to
    ``symbol_chips`` · :data:`MAX_MULTIPLE`, and the candidates lie in
    [MIN_ROWS_PER_CHIP, ``max_rows``], longest first.
    """
    k = np.arange(symbol_chips * MAX_MULTIPLE, 0, -1)
    found = k * float(period_rows) / symbol_chips
    return [float(p) for p in found if MIN_ROWS_PER_CHIP <= p <= max_rows]


def merge_candidates(candidates) -> list[float]:
    """Candidates longest first, dropping any within :data:`SAME_CANDIDATE` of a longer one."""
    kept: list[float] = []
    for p in sorted((float(c) for c in candidates if c is not None), reverse=True):
        if all(abs(p - q) > SAME_CANDIDATE * q for q in kept):
            kept.append(p)
    return kept


def _grid_indices(edges: np.ndarray, pitch: float) -> np.ndarray | None:
    """Chip index of each edge of one polarity, counted gap by gap.

    Counting from the previous edge, not from the first, keeps a guess that
    is a few percent off from slipping a chip over a long profile.
    """
    steps = np.rint(np.diff(edges) / pitch)
    if np.any(steps < 1):
        return None  # two edges of one polarity within half a chip: not this grid
    return np.concatenate([[0.0], np.cumsum(steps)])


def grid_regression(k: np.ndarray, e: np.ndarray, rising: np.ndarray, keep: np.ndarray):
    """Least squares e = a[rising] + P·k over the kept edges: one pitch, one intercept per polarity.

    Returns ``(P, a_falling, a_rising, sxx)`` or None when the kept edges do
    not determine the slope.
    """
    sk = np.zeros_like(k)
    se = np.zeros_like(e)
    centre = {}
    for polarity in (False, True):
        sel = keep & (rising == polarity)
        if sel.any():
            centre[polarity] = (float(k[sel].mean()), float(e[sel].mean()))
            sk[sel] = k[sel] - centre[polarity][0]
            se[sel] = e[sel] - centre[polarity][1]
    sxx = float(np.sum(sk * sk))
    if sxx <= 0:
        return None
    pitch = float(np.sum(sk * se) / sxx)
    if not pitch > 0:
        return None
    a = {pol: c[1] - pitch * c[0] for pol, c in centre.items()}
    return pitch, a.get(False, 0.0), a.get(True, 0.0), sxx


def edge_grid_fit(runs: Runs, guess_rows: float) -> GridFit | None:
    """Regress the profile's edges on a chip grid near ``guess_rows``.

    Rising and falling edges (between two decided runs) each get their own
    intercept and share the pitch. The chips are first counted gap by gap
    within each polarity, which tolerates a guess a few percent off; then,
    :data:`GRID_PASSES` times, every edge is counted afresh from the fitted
    grid and the fit repeated without the edges more than
    :data:`OUTLIER_CHIPS` off it, so that a stray edge (a footprint's cut,
    an ISP's ringing) costs only itself and does not tilt the grid.

    Returns
    -------
    GridFit or None
        None with fewer than :data:`MIN_GRID_EDGES` edges or when the edges
        of one polarity cannot lie on a grid of that pitch.
    """
    values = runs.values
    if values.size < 3 or not guess_rows > 0:
        return None
    real = (values[:-1] >= 0) & (values[1:] >= 0)
    e = runs.bounds[1:-1][real]
    rising = values[1:][real] == 1
    if e.size < MIN_GRID_EDGES:
        return None
    k = np.zeros(e.size)
    for polarity in (False, True):
        sel = rising == polarity
        if sel.sum() >= 2:
            counted = _grid_indices(e[sel], float(guess_rows))
            if counted is None:
                return None
            k[sel] = counted
    keep = np.ones(e.size, dtype=bool)
    for _ in range(GRID_PASSES):
        fit = grid_regression(k, e, rising, keep)
        if fit is None:
            return None
        pitch, a_falling, a_rising, sxx = fit
        intercept = np.where(rising, a_rising, a_falling)
        k = np.rint((e - intercept) / pitch)
        residual = e - intercept - pitch * k
        keep = np.abs(residual) <= OUTLIER_CHIPS * pitch
        if keep.sum() < MIN_GRID_EDGES:
            return None
    dof = max(1, int(keep.sum()) - 3)
    stderr = float(np.sqrt(np.sum(residual[keep] ** 2) / dof / sxx))
    rms = float(np.sqrt(np.mean(residual**2)) / pitch)
    spread = float(np.quantile(np.abs(residual), SPREAD_QUANTILE))
    return GridFit(pitch, stderr, rms, spread, int(e.size))


def choose_grid(fits) -> GridFit | None:
    """The chip grid among candidate fits: the longest that the edges lie on.

    Parameters
    ----------
    fits : iterable of (float, GridFit or None)
        Each candidate pitch (rows) with its :func:`edge_grid_fit`.

    Returns
    -------
    GridFit or None
        The longest fit within :data:`MAX_GRID_RESIDUAL` of its pitch, within
        :data:`MAX_GRID_SHIFT` of its candidate, and whose spread (rows) is
        within :data:`GRID_RESIDUAL_FACTOR` of the least among such fits (or
        within :data:`GRID_FLOOR_ROWS`); None if there is none.
    """
    valid = [fit for guess, fit in fits
             if fit is not None and fit.residual <= MAX_GRID_RESIDUAL
             and abs(fit.rows_per_chip / guess - 1.0) < MAX_GRID_SHIFT]
    if not valid:
        return None
    limit = max(GRID_RESIDUAL_FACTOR * min(fit.spread_rows for fit in valid), GRID_FLOOR_ROWS)
    return max((fit for fit in valid if fit.spread_rows <= limit), key=lambda fit: fit.rows_per_chip)
