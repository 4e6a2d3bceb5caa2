"""Hand shake: the LED's image moves, and each row sees it where it is then.

The offset of the LED image from its rest position is a path p(t) in pixels,
per axis:

``sinusoid``
    p(t) = A·sin(2π·f·t + φ): a tremor at f (physiological hand tremor is
    8–12 Hz).
``random_walk``
    A walk reflected at ±A: free knots X_k = X_{k−1} + δ_k at the nominal
    frame starts t = k·T_f (X_0 = 0, δ_k ~ Normal(0, step) per axis, drawn
    from a per-scene stream, :mod:`rollsim.numerics.frame_sequence`), joined by straight
    lines, and folded into [−A, A] by the triangle wave
    fold(X) = A − |((X + A) mod 4A) − 2A|. Folding the free walk is the same
    as reflecting every step at the bounds (up to the sign of the steps,
    which is symmetric), and costs one cumulative sum instead of a loop.

Within a frame the path is continuous and row y sees the LED centred at its
position at the middle of row y's exposure, t_k + y·t_row + t_exp/2 (the
rolling-shutter skew): a horizontal motion shears the footprint, a vertical
one stretches or squeezes it. At a constant vertical speed v (px/s) row y
sees the centre at c + v·y·t_row, so the rows the LED covers span
D/(1 − v·t_row) instead of D.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.numerics.frame_sequence import FrameSequence
from rollsim.numerics.seeds import rng as named_rng
from rollsim.numerics.jit import kernel
from rollsim.optics.footprint import Footprint, footprint_per_row

STREAM = "motion"


@dataclass(frozen=True)
class SinusoidPath:
    """p(t) = amplitude·sin(2π·frequency·t + phase), per axis.

    Parameters
    ----------
    amplitude_px : (float, float)
        x and y amplitude in pixels.
    frequency_hz : float
    phase_rad : (float, float)
        x and y phase at t = 0.
    """

    amplitude_px: tuple
    frequency_hz: float
    phase_rad: tuple

    def offset_px(self, t_s) -> np.ndarray:
        """Offsets (dx, dy) in pixels at times ``t_s``, shape (n, 2)."""
        cycles = np.mod(self.frequency_hz * np.asarray(t_s, dtype=np.float64), 1.0)[:, None]
        return np.asarray(self.amplitude_px) * np.sin(2.0 * np.pi * cycles + np.asarray(self.phase_rad))


def fold(x: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """Triangle wave: x reflected into [−bound, bound] (0 where bound is 0)."""
    bound = np.broadcast_to(bound, x.shape)
    period = 4.0 * bound
    safe = np.where(period > 0, period, 1.0)
    return np.where(period > 0, bound - np.abs(np.mod(x + bound, safe) - 2.0 * bound), 0.0)


class ReflectedWalkPath:
    """A random walk with knots at the frame starts, reflected at ±bound.

    Parameters
    ----------
    seed : int
        Scene seed.
    step_px : (float, float)
        Standard deviation of each per-frame step, x and y, in pixels.
    bound_px : (float, float)
        Reflecting bounds A, x and y, in pixels.
    frame_period_s : float
        Spacing T_f of the knots.
    """

    def __init__(self, seed: int, step_px, bound_px, frame_period_s: float):
        self.step_px = np.asarray(step_px, dtype=np.float64)
        self.bound_px = np.asarray(bound_px, dtype=np.float64)
        self.frame_period_s = frame_period_s
        self._steps = FrameSequence(seed, STREAM, 2)

    def knots_px(self, k) -> np.ndarray:
        """Free (unfolded) walk X_k at knots ``k``, shape (n, 2); X_k = 0 for k ≤ 0."""
        k = np.asarray(k, dtype=np.int64)
        return self._steps.walk(np.maximum(k, 0)) * self.step_px

    def offset_px(self, t_s) -> np.ndarray:
        """Offsets (dx, dy) in pixels at times ``t_s``, shape (n, 2)."""
        u = np.asarray(t_s, dtype=np.float64) / self.frame_period_s
        k = np.floor(u).astype(np.int64)
        first = int(k.min())
        knots = self.knots_px(np.arange(first, int(k.max()) + 2))
        w = (u - k)[:, None]
        free = knots[k - first] * (1.0 - w) + knots[k - first + 1] * w
        return fold(free, self.bound_px)


# Components of the handheld path's spectral synthesis, per axis.
TREMOR_COMPONENTS = 48
DRIFT_COMPONENTS = 24


def _band_sinusoids(rng: np.random.Generator, count: int, band_hz: tuple, rms: float, slope: float):
    """Frequencies, amplitudes and phases of ``count`` sinusoids whose sum has variance ``rms``²:
    one frequency log-uniform in each of ``count`` equal log-steps of ``band_hz`` (stratified, so
    that no two lie so close that they beat over seconds), amplitudes ∝ f^(−``slope``)."""
    edges = np.log(np.geomspace(band_hz[0], band_hz[1], count + 1))
    frequency = np.exp(rng.uniform(edges[:-1], edges[1:]))
    amplitude = frequency ** -slope
    # The sum of sinusoids a_k sin(...) has variance Σ a_k² / 2.
    amplitude *= rms / np.sqrt(0.5 * np.sum(amplitude**2))
    return frequency, amplitude, rng.uniform(0.0, 2.0 * np.pi, count)


class HandheldPath:
    """A camera held in the hand: physiological tremor on slow drift, in translation and roll.

    Each of x, y (px) and roll (rad, about the image centre) is a sum of
    sinusoids with random frequencies and phases drawn once per scene from
    its seed (spectral synthesis: a Gaussian process's sample, continuous
    in time, the same for any order of frames):

    * tremor: :data:`TREMOR_COMPONENTS` frequencies in ``tremor_band_hz``
      (physiological tremor lies at 8–12 Hz: R. J. Elble and W. C. Koller,
      *Tremor*, Johns Hopkins University Press, 1990), flat in amplitude;
    * drift: :data:`DRIFT_COMPONENTS` frequencies in ``drift_band_hz``,
      amplitude ∝ 1/f (power ∝ 1/f²: a wandering hold).

    Roll turns the LED's image about the frame's centre: with the LED's
    rest position r from the centre, a small roll θ moves it by θ·(−r_y, r_x).

    The amplitudes are the caller's. ``motion``'s defaults (0.05° rms of
    tremor, 0.3° of drift) are assumed: no published rms angle of a
    hand-held phone was found. Their angular rates (0.054 and 0.007 rad/s
    rms) lie inside the ±0.5 rad/s scale of a hand-held phone's gyroscope
    trace (Karpenko, Jacobs, Baek and Levoy, Stanford CSTR 2011-03,
    Fig. 1). Hand-held cameras also shake near 2 and 4 Hz (the shutter
    press; hand and forearm: *Jpn J Ergonomics* 31(6):399), which the two
    bands here leave out.

    Parameters
    ----------
    seed : int
        Scene seed.
    tremor_rms_px, drift_rms_px : float
        Standard deviation of each translation component per axis, px.
    roll_tremor_rms_rad, roll_drift_rms_rad : float
        Standard deviation of the roll's components, rad.
    tremor_band_hz, drift_band_hz : (float, float)
    lever_px : (float, float)
        The LED's rest position from the frame's centre (x, y), px.
    """

    def __init__(self, seed: int, tremor_rms_px: float, drift_rms_px: float, roll_tremor_rms_rad: float,
                 roll_drift_rms_rad: float, tremor_band_hz=(8.0, 12.0), drift_band_hz=(0.1, 1.0), lever_px=(0.0, 0.0)):
        rng = named_rng(seed, STREAM, 1)
        self.components = []  # per axis (x, y, roll): (frequency, amplitude, phase) arrays
        for tremor, drift in ((tremor_rms_px, drift_rms_px), (tremor_rms_px, drift_rms_px),
                              (roll_tremor_rms_rad, roll_drift_rms_rad)):
            parts = [_band_sinusoids(rng, TREMOR_COMPONENTS, tremor_band_hz, tremor, 0.0),
                     _band_sinusoids(rng, DRIFT_COMPONENTS, drift_band_hz, drift, 1.0)]
            self.components.append(tuple(np.concatenate(x) for x in zip(*parts)))
        self.lever_px = np.asarray(lever_px, dtype=np.float64)

    def axis(self, index: int, t_s) -> np.ndarray:
        """Component ``index`` (0: x px, 1: y px, 2: roll rad) at times ``t_s``."""
        frequency, amplitude, phase = self.components[index]
        t = np.asarray(t_s, dtype=np.float64)
        # Cycles modulo 1 before the sine: exact phases at long times.
        cycles = np.mod(t[:, None] * frequency[None, :], 1.0)
        return np.sin(2.0 * np.pi * cycles + phase[None, :]) @ amplitude

    def offset_px(self, t_s) -> np.ndarray:
        """Offsets (dx, dy) in pixels at times ``t_s``, shape (n, 2): translation plus roll about the centre."""
        return self.combine(self.axis(0, t_s), self.axis(1, t_s), self.axis(2, t_s))

    def combine(self, x_px: np.ndarray, y_px: np.ndarray, roll_rad: np.ndarray) -> np.ndarray:
        """The LED's offsets (dx, dy), shape (n, 2), from the three components: translation plus roll."""
        return np.stack([x_px - roll_rad * self.lever_px[1], y_px + roll_rad * self.lever_px[0]], axis=1)

    def on_grid(self, offsets_s) -> "HandheldGrid":
        """The path on a grid of times that moves with the frame: see :class:`HandheldGrid`."""
        return HandheldGrid(self, offsets_s)


class HandheldGrid:
    """A :class:`HandheldPath` at ``start + offsets_s`` for any start, the grid's sines computed once.

    sin(2πf(t₀ + τ) + φ) = sin a·cos b + cos a·sin b with a = 2πf·t₀ + φ and
    b = 2πf·τ: the (components × grid) tables of cos b and sin b are the
    same every frame (a frame's rows sit at fixed times from its start), so
    a frame costs the 3 × 72 sines of its start and two matrix products,
    not a sine per row and component (a hundredth of the time at 1080
    rows). The same values as :meth:`HandheldPath.offset_px` to rounding
    (tested to 1e-9 px at t = 10⁴ s).

    Parameters
    ----------
    path : HandheldPath
    offsets_s : ndarray, shape (n,)
        Times from the start, s (small: within a frame).
    """

    def __init__(self, path: HandheldPath, offsets_s):
        self.path = path
        tau = np.asarray(offsets_s, dtype=np.float64)
        self.tables = []
        for frequency, _amplitude, _phase in path.components:
            angle = 2.0 * np.pi * frequency[:, None] * tau[None, :]
            self.tables.append((np.cos(angle), np.sin(angle)))

    def offset_px(self, start_s: float) -> np.ndarray:
        """Offsets (dx, dy) in pixels at ``start_s + offsets_s``, shape (n, 2)."""
        values = []
        for (frequency, amplitude, phase), (cos_b, sin_b) in zip(self.path.components, self.tables):
            # Cycles modulo 1 before the sine: exact phases at long times.
            a = 2.0 * np.pi * np.mod(float(start_s) * frequency, 1.0) + phase
            values.append((amplitude * np.sin(a)) @ cos_b + (amplitude * np.cos(a)) @ sin_b)
        return self.path.combine(*values)


@dataclass(frozen=True)
class ShiftedGrid:
    """Any path at ``start + row_s + later_s``: its ``offset_px`` there (no tables to share).

    The times are summed in that order, as a frame's rows' mid-exposures
    always were (start, then the row's offset, then half the exposure), so a
    path's values keep their last bits.
    """

    path: object
    row_s: np.ndarray
    later_s: float

    def offset_px(self, start_s: float) -> np.ndarray:
        return self.path.offset_px(start_s + self.row_s + self.later_s)  # type: ignore[attr-defined]


def path_on_grid(path, row_s, later_s: float = 0.0):
    """``path`` at times ``start + row_s + later_s`` for any start: an object whose ``offset_px(start_s)``
    gives (n, 2) px (:class:`HandheldGrid` for a hand's path, :class:`ShiftedGrid` otherwise)."""
    row_s = np.asarray(row_s, dtype=np.float64)
    on_grid = getattr(path, "on_grid", None)
    return on_grid(row_s + later_s) if on_grid is not None else ShiftedGrid(path, row_s, float(later_s))


def path_from_params(params, seed: int, frame_period_s: float, px_per_rad: float = 0.0, lever_px=(0.0, 0.0)):
    """The path a :class:`rollsim.effects.motion.Motion` describes (``px_per_rad``: the image's
    pixels per radian of the camera's turn, focal length over pixel pitch; ``lever_px``: the LED's
    rest position from the frame's centre; both for ``handheld``)."""
    if params.mode == "handheld":
        return HandheldPath(seed, np.radians(params.tremor_deg) * px_per_rad, np.radians(params.drift_deg) * px_per_rad,
                            np.radians(params.roll_tremor_deg), np.radians(params.roll_drift_deg),
                            lever_px=lever_px)
    amplitude = (params.amplitude_x_px, params.amplitude_y_px)
    if params.mode == "sinusoid":
        return SinusoidPath(amplitude, params.frequency_hz, (np.radians(params.phase_x_deg), np.radians(params.phase_y_deg)))
    return ReflectedWalkPath(seed, (params.step_x_px, params.step_y_px), amplitude, frame_period_s)


def motion_footprint(path, centre_px, size_px: float, shape: str, frame_shape: tuple[int, int],
                     row_times_s: np.ndarray, edge: str = "exact") -> Footprint:
    """The LED footprint of one frame, each row seeing the LED where it is then.

    Parameters
    ----------
    path : SinusoidPath or ReflectedWalkPath
        Anything with ``offset_px(t_s) -> (n, 2)``.
    centre_px : (float, float)
        Rest position (x, y) of the LED centre, in pixels.
    size_px, shape, frame_shape, edge
        As for :func:`rollsim.optics.footprint.footprint`.
    row_times_s : ndarray, shape (height,)
        The time each frame row sees, in seconds (mid-exposure).
    """
    return footprint_at_offsets(path.offset_px(row_times_s), centre_px, size_px, shape, frame_shape, edge)


def footprint_at_offsets(offset_px: np.ndarray, centre_px, size_px: float, shape: str, frame_shape: tuple[int, int],
                         edge: str = "exact") -> Footprint:
    """:func:`motion_footprint` from the offsets (dx, dy) each frame row sees, shape (height, 2), px."""
    return footprint_per_row(centre_px[0] + offset_px[:, 0], centre_px[1] + offset_px[:, 1], size_px, shape,
                             frame_shape, edge)


def centre_seen_px(row_offsets_px: np.ndarray, centre_px) -> tuple[float, float]:
    """Where a frame shows the LED's centre: (x, y) in pixels.

    Row y sees the LED's centre at ``centre + offset_y`` (its offset at that
    row's time), so the centre is shown by the row nearest to the row its
    own offset puts it on: the discrete fixed point of y = c_y + dy_y. Its
    position is the one that row sees. A centre beyond the frame is placed
    by the edge row nearest to it.

    Parameters
    ----------
    row_offsets_px : ndarray, shape (height, 2)
        The offsets (dx, dy) each frame row sees, px.
    centre_px : (float, float)
        Rest position (x, y) of the LED's centre, px.
    """
    rows = np.arange(row_offsets_px.shape[0])
    seen = row_offsets_px + np.asarray(centre_px, dtype=np.float64)
    row = int(np.argmin(np.abs(rows - seen[:, 1])))
    return float(seen[row, 0]), float(seen[row, 1])


def moved_light(light: Footprint, row_offsets_px: np.ndarray, frame_shape: tuple[int, int]) -> Footprint:
    """A static light moved as each row sees it: row y shows the light at (x − dx_y, y − dy_y).

    The glare halo and the LED face's profile are images of the LED: a
    translation of the LED translates them, so a moving LED's light is the
    rest-position light shifted per row (the rolling-shutter skew), sampled
    with bilinear interpolation. The shift is exact for whole-pixel offsets;
    a sub-pixel one smooths the light over a pixel, as bilinear sampling
    does (each axis's variance grows by f(1 − f), f the offset's fraction),
    and keeps its sum and moves its centroid by the offset exactly wherever
    the light stays inside the frame. Outside the light's box it is 0, but
    past the frame's edge the rest light is not known: where its box
    reaches an edge of the frame (an LED that fills the frame, a halo), the
    edge's values continue it, so a shift does not draw a dark band there.

    Parameters
    ----------
    light : Footprint
        The light at rest (its box and values).
    row_offsets_px : ndarray, shape (height, 2)
        Offset (dx, dy) of the LED, in pixels, at the time each frame row sees.
    frame_shape : (int, int)
        (height, width) of the frame.

    Returns
    -------
    Footprint
        The moved light on the rows and columns it can reach.
    """
    return RestLight.of(light, frame_shape).moved(row_offsets_px)


@dataclass(frozen=True)
class RestLight:
    """A light at rest, padded once per scene so that each frame only samples it (:func:`moved_light`).

    Attributes
    ----------
    padded : ndarray
        The light's values with one row and column on each side: 0 (the
        light outside its box), or the edge's values where the box reaches
        an edge of the frame (the light goes on beyond it, unknown).
    rows, cols : slice
        The light's box in the frame.
    frame_shape : (int, int)
    """

    padded: np.ndarray
    rows: slice
    cols: slice
    frame_shape: tuple

    @classmethod
    def of(cls, light: Footprint, frame_shape: tuple[int, int]) -> "RestLight":
        height, width = frame_shape
        padded = np.pad(np.asarray(light.coverage, dtype=np.float64), 1)
        if light.coverage.size:
            if light.rows.start == 0:
                padded[0] = padded[1]
            if light.rows.stop == height:
                padded[-1] = padded[-2]
            if light.cols.start == 0:
                padded[:, 0] = padded[:, 1]
            if light.cols.stop == width:
                padded[:, -1] = padded[:, -2]
        return cls(padded, light.rows, light.cols, tuple(frame_shape))

    def moved(self, row_offsets_px: np.ndarray) -> Footprint:
        """The light as each frame row sees it, moved by that row's offset (dx, dy), px (:func:`moved_light`)."""
        height, width = self.frame_shape
        if min(self.padded.shape) <= 2:  # an empty light (its box has no pixel)
            return Footprint(self.rows, self.cols, self.padded[1:-1, 1:-1])
        r0, c0 = self.rows.start, self.cols.start
        dx, dy = row_offsets_px[:, 0], row_offsets_px[:, 1]
        rows = _moved_span(self.rows, height, dy)
        cols = _moved_span(self.cols, width, dx)
        if rows.stop <= rows.start or cols.stop <= cols.start:
            return Footprint(slice(0, 0), slice(0, 0), np.zeros((0, 0)))
        y = np.arange(rows.start, rows.stop)
        # Output row y reads the light's rows i0, i0 + 1 around y − dy_y with weights 1 − a, a, and
        # column x its columns around x − dx_y: x − c0 + 1 + k and the next, with weights 1 − b, b.
        source = y - dy[y] - r0 + 1.0
        i0 = np.floor(source).astype(np.int64)
        a = source - i0
        shift = -dx[y]
        k = np.floor(shift).astype(np.int64)
        b = shift - k
        first_col = cols.start - c0 + 1
        out = np.empty((y.size, cols.stop - cols.start))
        compiled = _bilinear_rows.compiled
        if compiled is not None:
            compiled(self.padded, i0, a, k, b, first_col, out)
        else:
            _bilinear_rows_numpy(self.padded, i0, a, k, b, first_col, out)
        return Footprint(rows, cols, out)


def _moved_span(span: slice, size: int, shift_px: np.ndarray) -> slice:
    """The light's span along one axis widened by its largest shifts, within 0 … ``size``; a span that
    reaches an edge of the frame keeps reaching it (the light is continued past that edge)."""
    return slice(0 if span.start == 0 else max(0, int(np.floor(span.start + shift_px.min())) - 1),
                 size if span.stop == size else min(size, int(np.ceil(span.stop + shift_px.max())) + 1))


def _bilinear_rows_numpy(padded, i0, a, k, b, first_col, out) -> None:
    """:data:`_bilinear_rows` in numpy: the same operations in the same order (the same bits)."""
    last_row, last_col = padded.shape[0] - 1, padded.shape[1] - 1
    upper, lower = np.clip(i0, 0, last_row), np.clip(i0 + 1, 0, last_row)
    weight = a[:, None]
    vertical = (1.0 - weight) * padded[upper] + weight * padded[lower]
    index = first_col + np.arange(out.shape[1])[None, :] + k[:, None]
    left = np.take_along_axis(vertical, np.clip(index, 0, last_col), axis=1)
    right = np.take_along_axis(vertical, np.clip(index + 1, 0, last_col), axis=1)
    across = b[:, None]
    out[:] = (1.0 - across) * left + across * right


@kernel
def _bilinear_rows(padded, i0, a, k, b, first_col, out):  # pragma: no cover - compiled by numba
    # Two passes per row, as the numpy twin: the two source rows blended once into
    # ``vertical`` (over the columns the row reads), then each output pixel from two of
    # those. Rows taken as 1-D views and the clamp kept out of the inner loop let it vectorise.
    last_row = padded.shape[0] - 1
    last_col = padded.shape[1] - 1
    width = out.shape[1]
    vertical = np.empty(padded.shape[1])
    for r in range(out.shape[0]):
        source_upper = padded[min(max(i0[r], 0), last_row)]
        source_lower = padded[min(max(i0[r] + 1, 0), last_row)]
        down = a[r]
        up = 1.0 - down
        offset = first_col + k[r]
        lo = min(max(offset, 0), last_col)
        hi = min(max(offset + width, 0), last_col)
        for j in range(lo, hi + 1):
            vertical[j] = up * source_upper[j] + down * source_lower[j]
        across = b[r]
        stay = 1.0 - across
        row = out[r]
        # Columns whose two sources lie inside the padded light need no clamp.
        inner_lo = min(max(-offset, 0), width)
        inner_hi = max(min(last_col - offset, width), inner_lo)
        for c in range(inner_lo, inner_hi):
            row[c] = stay * vertical[offset + c] + across * vertical[offset + c + 1]
        for c in range(0, inner_lo):
            row[c] = stay * vertical[min(max(offset + c, 0), last_col)] \
                + across * vertical[min(max(offset + c + 1, 0), last_col)]
        for c in range(inner_hi, width):
            row[c] = stay * vertical[min(max(offset + c, 0), last_col)] \
                + across * vertical[min(max(offset + c + 1, 0), last_col)]
