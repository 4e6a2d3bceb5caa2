"""Channel models of the event simulator: which emissions the camera receives.

A channel decides, for every PHY-SDU emission of one broadcast, one of three
outcomes (``uint8`` codes):

``RECEIVED`` (0)
    wholly inside a capture window (an ON slot) and decoded;
``GAP_LOSS`` (1)
    not wholly inside a capture window: lost in the inter-frame gap (IFG) or
    outside the LED's rows (an OFF slot);
``DECODE_ERROR`` (2)
    inside a capture window but wrongly decoded, with probability ``p_e``.

Three models, from the most abstract to CamComSim's own:

:class:`MmbpChannel`
    The paper's MMBP (§4.1.2): an integer cycle of ``M`` ON and ``N`` OFF
    slots, one emission per slot, a uniform random phase per run.
:class:`TimedChannel`
    Continuous time from the scene's physics: frame period ``T_f``, capture
    window ``W`` per frame, PHY-SDU duration ``T_p``, optional frame jitter.
    Without jitter and with ``T_f = C T_p``, ``W = (M + 1) T_p`` it is the
    MMBP exactly; with jitter the Fig. 12 artefact disappears.
:class:`CamcomsimChannel`
    CamComSim 1.0's channel (100 us slots, a random 0..9 slot gap between
    emissions, the measured ROI table), see its docstring for every place
    where it differs from the paper's text.

Every channel is a frozen, picklable dataclass (it travels to worker
processes). ``channel.open_run(seed_sequence)`` starts one broadcast with its
own random phase and returns a run object whose ``next_block(count)`` gives
the outcome codes of the next ``count`` emissions (tx ``i, i+1, ...``).
Randomness comes only from the seed sequence, never from the wall clock:
given it and the sequence of block sizes, the codes are fixed. (For
``mmbp`` and ``timed`` they do not even depend on the block sizes; the
``camcomsim`` run draws its slot gaps and its decode draws block by block.)
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import ClassVar, Protocol

import numpy as np

from rollsim.plumbing.validation import as_count as _as_count
from rollsim.plumbing.validation import as_positive as _as_duration
from rollsim.plumbing.validation import as_probability as _as_probability
from rollsim.numerics.gaussian import truncated_normal as _truncated_normal

__all__ = [
    "CAMCOMSIM_ROI_TABLE",
    "CAMCOMSIM_SLOT_S",
    "DECODE_ERROR",
    "GAP_LOSS",
    "RECEIVED",
    "CamcomsimChannel",
    "ChannelModel",
    "ChannelRun",
    "MmbpChannel",
    "TimedChannel",
    "camcomsim_frame_slots",
    "camcomsim_roi",
    "camcomsim_sdu_slots",
    "camcomsim_slot_sequence",
    "camcomsim_visible_slots",
]

RECEIVED = 0
GAP_LOSS = 1
DECODE_ERROR = 2

# CamComSim's time unit: the frame is cut into slots of 100 us.
CAMCOMSIM_SLOT_S = 1e-4
# CamComSim's measured ROI ratio (paper Fig. 11, orange curve), indexed by
# int(d / 5 + 0.5) with d in cm; 0 past the end of the table.
CAMCOMSIM_ROI_TABLE = (
    1.0,
    0.98452928286029235,
    0.72436947075060389,
    0.52775098804825378,
    0.42458059355383677,
    0.31179044636046831,
    0.25630101117437368,
    0.16225149678257165,
    0.05831170015338602,
)
# CamComSim's PHY-SDU delimiter, counted as 4 chips whatever the line code.
_CAMCOMSIM_SYNC_CHIPS = 4
# Chips per bit (CamComSim's Rll.codeLen): exact rationals for the robust path.
_CAMCOMSIM_CODE_LEN = {"manchester": Fraction(2), "4b6b": Fraction(3, 2)}
# A value within this distance of an integer is that integer in the robust
# ceil/floor/round of CamComSim's frame arithmetic: far above float64 noise
# (~1e-14 on values ~ 1e2), far below any meaningful difference (1 ps in ms).
_INTEGER_TOLERANCE = 1e-9
# 100 us as an exact rational, for the robust PHY-SDU duration.
_SLOT_FRACTION = Fraction(1, 10_000)


# ----------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------






def _outcomes(in_window: np.ndarray, uniform: np.ndarray, p_e: float) -> np.ndarray:
    """Outcome codes from window membership and one U[0, 1) draw per emission.

    ``u < p_e`` is a decode error: never for ``p_e = 0``, always for
    ``p_e = 1`` (``u < 1``). Every emission consumes its draw, in or out of
    the window, so the stream of draws does not depend on the window.
    """
    inside = in_window.view(np.uint8)
    error = (uniform < p_e).view(np.uint8)
    # 1 - inside: gap loss; 2 * (inside & error): decode error; else 0.
    return (1 - inside) + ((inside & error) << 1)


# ----------------------------------------------------------------------------
# What every channel model provides
# ----------------------------------------------------------------------------
class ChannelRun(Protocol):
    """One broadcast on a channel: outcome codes of the next emissions."""

    def next_block(self, count: int) -> np.ndarray:
        """Outcome codes (:data:`RECEIVED`, :data:`GAP_LOSS`, :data:`DECODE_ERROR`) of the next ``count`` emissions."""


class ChannelModel(abc.ABC):
    """What the event simulator needs of a channel model; the three models below share it.

    A model names its ``kind``, says how far the clock advances per emission,
    gives its JSON-ready ``parameters`` and opens independent runs.
    """

    kind: ClassVar[str]
    notes: ClassVar[tuple] = ()

    @property
    @abc.abstractmethod
    def emission_duration_s(self) -> float:
        """Clock advance per emission, seconds."""

    @property
    def emission_duration_100us(self) -> float:
        """Clock advance per emission in CamComSim's unit (100 us)."""
        return self.emission_duration_s / CAMCOMSIM_SLOT_S

    @abc.abstractmethod
    def parameters(self) -> dict:
        """JSON-ready parameters of the channel, ``kind`` included."""

    @abc.abstractmethod
    def open_run(self, seed_sequence: np.random.SeedSequence) -> ChannelRun:
        """Start one broadcast, its randomness drawn from ``seed_sequence``."""


# ----------------------------------------------------------------------------
# MMBP
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class MmbpChannel(ChannelModel):
    """The MMBP channel (paper §4.1.2): a cycle of ``M`` ON and ``N`` OFF slots.

    Emission ``i`` falls in slot ``(s + i) mod C``, ``C = M + N``, with the
    phase ``s`` uniform on ``0 .. C-1`` per run; slots ``0 .. M-1`` are ON.
    In an ON slot the emission is received with probability ``1 - p_e``,
    independently of all others; in an OFF slot it is lost. These are the
    conventions of :mod:`rollsim.channel.analytic`, so the simulator's
    statistics converge to its exact results.

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle, >= 0, with ``M + N >= 1``.
    p_e : float
        PHY-SDU error probability in an ON slot, in [0, 1].
    sdu_duration_s : float
        Duration of one slot (one PHY-SDU emission) in seconds, > 0; the
        simulated clock advances by it at every emission.
    """

    M: int
    N: int
    p_e: float
    sdu_duration_s: float

    kind = "mmbp"

    def __post_init__(self):
        M = _as_count(self.M, "M")
        N = _as_count(self.N, "N")
        if M + N < 1:
            raise ValueError("the cycle C = M + N must be >= 1 slot, got M = N = 0")
        object.__setattr__(self, "M", M)
        object.__setattr__(self, "N", N)
        object.__setattr__(self, "p_e", _as_probability(self.p_e, "p_e"))
        object.__setattr__(self, "sdu_duration_s", _as_duration(self.sdu_duration_s, "sdu_duration_s"))

    @property
    def cycle_slots(self) -> int:
        """``C = M + N``."""
        return self.M + self.N

    @property
    def emission_duration_s(self) -> float:
        """Clock advance per emission, seconds."""
        return self.sdu_duration_s

    def parameters(self) -> dict:
        """JSON-ready parameters of the channel."""
        return {"kind": self.kind, "M": self.M, "N": self.N, "p_e": self.p_e, "sdu_duration_s": self.sdu_duration_s}

    def open_run(self, seed_sequence: np.random.SeedSequence) -> "_MmbpRun":
        """Start one broadcast: draw the phase from ``seed_sequence``."""
        return _MmbpRun(self, np.random.default_rng(seed_sequence))


# Cycles up to this many slots are tiled once per run (slicing a pattern is
# cheaper than a modulo per emission); longer ones, up to the 10**7-slot
# frames a scene allows, are computed per emission so that a run's memory
# does not grow with M + N.
_TILE_MAX_CYCLE = 1 << 16


class _MmbpRun:
    def __init__(self, channel: MmbpChannel, rng: np.random.Generator):
        self._channel = channel
        self._rng = rng
        C = channel.cycle_slots
        self._cycle: np.ndarray | None = np.arange(C) < channel.M if C <= _TILE_MAX_CYCLE else None
        self._slot = int(rng.integers(C))  # slot of the next emission
        self._tiled: np.ndarray | None = self._cycle

    def next_block(self, count: int) -> np.ndarray:
        C = self._channel.cycle_slots
        if self._cycle is None:
            on = (self._slot + np.arange(count, dtype=np.int64)) % C < self._channel.M
        else:
            tiled = self._tiled
            if tiled is None or tiled.size < count + C:
                tiled = self._tiled = np.resize(self._cycle, count + C)
            on = tiled[self._slot : self._slot + count]
        self._slot = (self._slot + count) % C
        return _outcomes(on, self._rng.random(count), self._channel.p_e)


# ----------------------------------------------------------------------------
# Timed (continuous time, frame jitter)
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class TimedChannel(ChannelModel):
    """Continuous-time channel from frame and PHY-SDU timing, with frame jitter.

    Emission ``i`` occupies ``[i T_p, (i + 1) T_p]``. Frame ``k`` captures
    the LED during ``[t_k, t_k + W]`` with ``t_k = phi + k T_f + eps_k``; the
    phase ``phi`` is uniform on ``[0, T_f)`` per run. An emission is received
    only if it lies wholly inside some frame's window, and then with
    probability ``1 - p_e``.

    Frame jitter: ``eps_k`` are i.i.d. per frame (not a random walk: the
    frame clock does not drift), Normal(0, ``frame_jitter_s``) truncated to
    ``[-T_f/2, T_f/2]``, so that frames keep their order
    (``t_{k+1} >= t_k``). For ``frame_jitter_s <= T_f / 10`` the truncation
    removes less than 1e-6 of the probability mass. Each frame's jitter
    comes from one uniform draw of a stream of its own, so it does not
    depend on the emissions.

    Parameters
    ----------
    frame_period_s : float
        ``T_f``, seconds between frame starts, > 0.
    capture_window_s : float
        ``W``, seconds per frame during which the LED's rows are exposed,
        >= 0 (see :func:`rollsim.channel.scene_channel.capture_window_from_scene`).
    sdu_duration_s : float
        ``T_p``, seconds per PHY-SDU, > 0.
    p_e : float
        Decode error probability inside a window, in [0, 1].
    frame_jitter_s : float, default 0
        Standard deviation of the frame start jitter before truncation,
        seconds, >= 0.

    Notes
    -----
    With ``frame_jitter_s = 0``, ``T_f = C T_p`` and ``W = (M + 1) T_p``
    exactly ``M`` consecutive emissions per frame fit (those starting in
    ``(phi, phi + M T_p]`` modulo ``T_f``), which is the MMBP with ``M`` ON
    and ``C - M`` OFF slots and a uniform phase (see
    :func:`rollsim.channel.analytic.mmbp_slots_from_physics`).
    """

    frame_period_s: float
    capture_window_s: float
    sdu_duration_s: float
    p_e: float
    frame_jitter_s: float = 0.0

    kind = "timed"

    def __post_init__(self):
        object.__setattr__(self, "frame_period_s", _as_duration(self.frame_period_s, "frame_period_s"))
        object.__setattr__(self, "capture_window_s", _as_duration(self.capture_window_s, "capture_window_s", True))
        object.__setattr__(self, "sdu_duration_s", _as_duration(self.sdu_duration_s, "sdu_duration_s"))
        object.__setattr__(self, "p_e", _as_probability(self.p_e, "p_e"))
        object.__setattr__(self, "frame_jitter_s", _as_duration(self.frame_jitter_s, "frame_jitter_s", True))

    @property
    def jitter_bound_s(self) -> float:
        """Largest ``|eps_k|``: ``T_f / 2`` with jitter, 0 without."""
        return 0.5 * self.frame_period_s if self.frame_jitter_s > 0.0 else 0.0

    @property
    def emission_duration_s(self) -> float:
        return self.sdu_duration_s

    def parameters(self) -> dict:
        return {
            "kind": self.kind,
            "frame_period_s": self.frame_period_s,
            "capture_window_s": self.capture_window_s,
            "sdu_duration_s": self.sdu_duration_s,
            "p_e": self.p_e,
            "frame_jitter_s": self.frame_jitter_s,
        }

    def open_run(self, seed_sequence: np.random.SeedSequence) -> "_TimedRun":
        """Start one broadcast: phase and frame jitter from ``seed_sequence``."""
        emissions, frames = seed_sequence.spawn(2)
        return _TimedRun(self, np.random.default_rng(emissions), np.random.default_rng(frames))


class _TimedRun:
    def __init__(self, channel: TimedChannel, rng: np.random.Generator, frame_rng: np.random.Generator):
        self._ch = channel
        self._rng = rng
        self._frame_rng = frame_rng
        T_f, W, T_p = channel.frame_period_s, channel.capture_window_s, channel.sdu_duration_s
        J = channel.jitter_bound_s
        self._phase = float(rng.random()) * T_f
        self._next = 0  # tx index of the next emission
        # Emission [a, a + T_p] is inside window k iff t_k in [a + T_p - W, a];
        # with |eps_k| <= J the candidate frames are those with nominal start
        # in [a + T_p - W - J, a + J]: at most floor((W - T_p + 2J) / T_f) + 1
        # of them. One more on each side guards against rounding in the
        # frame index; the containment test itself is exact.
        self._never = W < T_p
        # Consecutive frame starts are at most T_f + 2J apart: a window
        # longer than that plus T_p holds every emission.
        self._always = W - T_p >= T_f + 2.0 * J
        self._candidates = 0 if (self._never or self._always) else int((W - T_p + 2.0 * J) // T_f) + 3
        self._eps = np.zeros(0)
        self._eps_first: int | None = None  # frame index of self._eps[0]

    def _frame_jitter(self, k_first: int, k_stop: int) -> np.ndarray:
        """``eps_k`` for frames ``k_first .. k_stop - 1`` (non-decreasing calls)."""
        first = k_first if self._eps_first is None else self._eps_first
        have_stop = first + self._eps.size
        if k_stop > have_stop:
            u = self._frame_rng.random(k_stop - have_stop)
            new = _truncated_normal(u, self._ch.frame_jitter_s, self._ch.jitter_bound_s)
            self._eps = np.concatenate([self._eps, new])
        # Frames before k_first are never needed again: keep memory flat.
        drop = k_first - first
        if drop > 0:
            self._eps = self._eps[drop:]
            first = k_first
        self._eps_first = first
        return self._eps[k_first - first : k_stop - first]

    def _in_window(self, tx: np.ndarray) -> np.ndarray:
        ch = self._ch
        if self._never:
            return np.zeros(tx.size, dtype=bool)
        if self._always:
            return np.ones(tx.size, dtype=bool)
        T_f, W, T_p, J = ch.frame_period_s, ch.capture_window_s, ch.sdu_duration_s, ch.jitter_bound_s
        start = tx * T_p
        end = start + T_p
        k_lo = np.ceil((end - W - self._phase - J) / T_f).astype(np.int64) - 1
        inside = np.zeros(tx.size, dtype=bool)
        if J > 0.0:
            eps = self._frame_jitter(int(k_lo[0]), int(k_lo[-1]) + self._candidates)
            base = int(k_lo[0])
        for j in range(self._candidates):
            k = k_lo + j
            t_k = self._phase + k * T_f
            if J > 0.0:
                t_k = t_k + eps[k - base]
            inside |= (t_k <= start) & (t_k + W >= end)
        return inside

    def next_block(self, count: int) -> np.ndarray:
        tx = np.arange(self._next, self._next + count, dtype=np.int64)
        self._next += count
        return _outcomes(self._in_window(tx), self._rng.random(count), self._ch.p_e)


# ----------------------------------------------------------------------------
# CamComSim 1.0
# ----------------------------------------------------------------------------
def _f32(x) -> np.float32:
    return np.float32(x)


def _ceil_robust(x: float) -> int:
    return math.ceil(x - _INTEGER_TOLERANCE)


def _floor_robust(x: float) -> int:
    return math.floor(x + _INTEGER_TOLERANCE)


def camcomsim_frame_slots(frame_period_ms: float, *, java_float32: bool = False) -> int:
    """Slots of 100 us per frame: ``round(T_f * 10)`` with ``T_f`` in ms.

    Rounds half up, like Java's ``Math.round``. ``java_float32=True``
    multiplies in float32, as CamComSim does with its ``float`` field.

    Parameters
    ----------
    frame_period_ms : float
        Frame period in milliseconds, > 0 (CamComSim's default 33.3).

    Returns
    -------
    int
        Slots per frame, >= 1.
    """
    T_f = _as_duration(frame_period_ms, "frame_period_ms")
    if java_float32:
        slots = int(np.floor(_f32(T_f) * _f32(10) + _f32(0.5)))
    else:
        slots = _floor_robust(T_f * 10.0 + 0.5)
    if slots < 1:
        raise ValueError(f"frame_period_ms must give at least one 100 us slot, got {frame_period_ms!r}")
    return slots


def camcomsim_roi(distance_cm: float) -> float:
    """CamComSim's measured ROI ratio at ``distance_cm``.

    ``CAMCOMSIM_ROI_TABLE[int(d / 5 + 0.5)]``: the nearest 5 cm step, half up;
    0 from 42.5 cm on (past the end of the table: the LED is never seen).
    """
    d = _as_duration(distance_cm, "distance_cm", allow_zero=True)
    index = int(d / 5.0 + 0.5)
    return CAMCOMSIM_ROI_TABLE[index] if index < len(CAMCOMSIM_ROI_TABLE) else 0.0


def camcomsim_visible_slots(
    frame_period_ms: float, ifg_ratio: float, distance_cm: float, *, java_float32: bool = False
) -> int:
    """Slots per frame during which the LED is captured (from the frame start).

    ``floor(ceil(T_f (1 - ifg_ratio)) * 10 * ROI(d))``: the capture time is
    rounded *up to whole milliseconds* before the ROI scales it.

    Parameters
    ----------
    frame_period_ms : float
        Frame period in milliseconds, > 0.
    ifg_ratio : float
        Inter-frame gap / frame period, in [0, 1] (CamComSim treats >= 1 as
        no capture at all).
    distance_cm : float
        LED-camera distance in cm, >= 0 (see :func:`camcomsim_roi`).
    java_float32 : bool, default False
        ``False``: float64, where values within 1e-9 of an integer count as
        that integer before the ceil and floor. ``True``: CamComSim's float32
        product ``T_f * (1 - ifg)`` (its ``float`` fields), then float64.

    Returns
    -------
    int
        Visible slots, >= 0.

    Notes
    -----
    The ceil is a floating-point trap. ``T_f = 1000/30`` ms and IFG 0.1 give
    ``T_f * 0.9 = 30.000000000000004`` in float64, whose plain ceil is 31
    (305 visible slots at 5 cm instead of 295); float32 gives 29.999998,
    ceil 30. ``T_f = 33.3`` gives 29.97 (float32 29.969999), ceil 30, either
    way. Both modes here give 30 for ``1000/30``.
    """
    T_f = _as_duration(frame_period_ms, "frame_period_ms")
    ifg = _as_probability(ifg_ratio, "ifg_ratio")
    roi = camcomsim_roi(distance_cm)
    if java_float32:
        on_ratio = _f32(0) if _f32(ifg) >= _f32(1) else _f32(1) - _f32(ifg)
        on_ms = math.ceil(float(_f32(T_f) * on_ratio))
        return int(on_ms * 10 * roi)
    on_ms = _ceil_robust(T_f * (1.0 - ifg))
    return max(0, _floor_robust(on_ms * 10 * roi))


def camcomsim_sdu_slots(
    header_bits: int, payload_bits: int, clock_hz: float, line_code: str = "manchester", *, java_float32: bool = False
) -> int:
    """PHY-SDU duration in whole 100 us slots, truncated: ``int((4 + k (H + P)) / f / 100 us)``.

    ``k = 2`` chips per bit for Manchester, 1.5 for 4B6B; 4 SYNC chips. As in
    CamComSim, the parity bits are not counted (the paper's §6.2.2 counts
    them) and neither is 4B6B padding.

    Parameters
    ----------
    header_bits, payload_bits : int
        ``H`` and ``P`` in bits.
    clock_hz : float
        Chip rate ``f`` in Hz, > 0.
    line_code : {'manchester', '4b6b'}
    java_float32 : bool, default False
        ``False``: exact rational arithmetic (the chips and the clock are
        exact binary numbers). ``True``: CamComSim's float32 arithmetic,
        ``(int)(10 * (1000f * (nbBits / f)))``.

    Returns
    -------
    int
        Slots per PHY-SDU, >= 1.

    Notes
    -----
    Truncating a float quotient loses a whole slot whenever the quotient
    rounds just below an integer: naively in float64,
    ``int((4 + 2*1) / 5000 / 1e-4)`` is 11 instead of 12. CamComSim's
    float32 path has the same fault at other values: 15 instead of 16 for
    ``H + P = 2`` at 5 kHz, and about one case in five over
    ``H + P < 200`` at 1 to 10 kHz; at 8 kHz with ``H + P = 24`` both
    give the exact 65.
    """
    H = _as_count(header_bits, "header_bits")
    P = _as_count(payload_bits, "payload_bits", 1)
    f = _as_duration(clock_hz, "clock_hz")
    if line_code not in _CAMCOMSIM_CODE_LEN:
        raise ValueError(f"line_code must be one of {sorted(_CAMCOMSIM_CODE_LEN)}, got {line_code!r}")
    k = _CAMCOMSIM_CODE_LEN[line_code]
    chips = _CAMCOMSIM_SYNC_CHIPS + k * (H + P)
    if java_float32:
        chips32 = _f32(_CAMCOMSIM_SYNC_CHIPS) + _f32(float(k)) * _f32(H + P)
        ms = _f32(1000) * (chips32 / _f32(f))
        slots = int(float(ms) * 10.0)
    else:
        slots = math.floor(chips / Fraction(f) / _SLOT_FRACTION)
    if slots < 1:
        raise ValueError(
            f"clock_hz = {clock_hz!r}: the PHY-SDU ({float(chips)} chips) is shorter than one 100 us slot, "
            "which CamComSim's clock cannot represent"
        )
    return slots


def camcomsim_slot_sequence(start_slot: int, increments: np.ndarray, frame_slots: int) -> np.ndarray:
    """Slots of successive emissions: ``slot <- (slot + increment) mod frame_slots``.

    The recurrence is a cumulative sum modulo ``frame_slots``; it is
    evaluated as ``(start + cumsum(increments)) mod frame_slots`` in int64.

    Parameters
    ----------
    start_slot : int
        Slot before the first increment.
    increments : ndarray of int
        ``duration + U{0..9}`` per emission, in slots.
    frame_slots : int
        Slots per frame, >= 1.

    Returns
    -------
    ndarray of int64
        Slot of each emission, in ``[0, frame_slots)``.
    """
    total = np.cumsum(increments, dtype=np.int64)
    total += start_slot
    return np.remainder(total, frame_slots, out=total)


@dataclass(frozen=True)
class CamcomsimChannel(ChannelModel):
    """CamComSim 1.0's channel, reproduced from its source (``topology/Channel.java``).

    Time is cut into slots of 100 us; a frame is ``frame_slots`` slots, the
    first ``visible_slots`` of which capture the LED. Per run the start slot
    is uniform on ``[0, frame_slots)``; before every emission
    ``slot <- (slot + sdu_slots + U{0..9}) mod frame_slots``. The emission is
    lost in the gap if ``slot + sdu_slots >= visible_slots``; otherwise it
    is received with probability ``1 - p_e`` (else a decode error). The
    simulated clock advances by ``sdu_slots`` per emission only, not by the
    random gap: ``duration100Us = emissions * sdu_slots``.

    Build it from CamComSim's parameters with :meth:`from_parameters`.

    Parameters
    ----------
    frame_slots : int
        Slots per frame, >= 1 (:func:`camcomsim_frame_slots`).
    visible_slots : int
        Slots per frame that capture the LED, >= 0
        (:func:`camcomsim_visible_slots`).
    sdu_slots : int
        Slots per PHY-SDU, >= 1 (:func:`camcomsim_sdu_slots`).
    p_e : float
        Decode error probability of a captured PHY-SDU, in [0, 1].

    Notes
    -----
    Where CamComSim differs from the paper's text:

    * **Not an MMBP with PHY-SDU slots.** The paper (§4.1.2) cycles through
      ``M + N`` slots of one PHY-SDU each, deterministically. CamComSim
      cuts the frame into 100 us slots and adds a random gap of
      ``U{0..9}`` slots (0 to 0.9 ms) before every emission. This random
      drift, not a frame-period jitter, is what removes the Fig. 12
      artefact in CamComSim.
    * **The clock ignores that gap.** Emissions are spaced
      ``sdu_slots + U`` slots apart on the channel, but the duration (and so
      goodput and throughput) counts ``sdu_slots`` per emission: the
      transmitter effectively sends ``(d + 4.5) / d`` times faster than its
      clock says (7% for ``d = 65``).
    * **Duration without the parity bits.** ``(4 + k (H + P)) / f``,
      truncated to whole slots; §6.2.2 adds 2 parity bits.
    * **Measured ROI.** The visible slots use the measured ROI table
      (:data:`CAMCOMSIM_ROI_TABLE`, Fig. 11), not Eq. 10; the LED size,
      focal length and sensor size of Table 1 play no part. From 42.5 cm on
      the ROI is 0 and nothing is ever received.
    * **Capture time rounded up to whole milliseconds** before the ROI
      scales it (``ceil(T_f (1 - IFG))``), with the float trap described in
      :func:`camcomsim_visible_slots`.
    * **Gap check at the emission's start slot only.** A PHY-SDU starting
      in the visible part and running past it is lost (correct), but the
      visible part always starts at slot 0 of the frame: the LED's rows
      sit at the top of the picture.
    * **Generation size counts packets.** ``G`` ("message size, bytes" in
      Table 1) is the number of PHY-SDUs CamComSim builds and compares with
      the count of distinct received ones, so it is a number of packets;
      ``H`` and ``P`` are bits. rollsim reads ``G`` as bytes on every
      channel (``ceil(8 G / P)`` packets, see
      :mod:`rollsim.channel.scene_channel`).
    * **Packets told apart without sequence numbers.** CamComSim counts
      distinct PHY-SDUs by object identity and fills the header with
      random bytes, so ``H`` only lengthens the PHY-SDU: with too few
      header bits, even 0, the sequence numbers a real header would carry
      wrap and no packet is lost for it. This channel, like the whole event
      simulator, tracks packets by index: such a scene loads for it alone
      (:func:`rollsim.channel.scene_channel.scene_relaxations`).
    * **Distance 0.** The ROI table gives 1 at 0 cm (CamComSim's script
      sweeps ``d = 0``); the thin lens plays no part, so any distance
      >= 0 is valid here.
    * **p_e = 1 inside the window.** CamComSim classifies a loss by testing
      ``channelError == 1``, so with ``p_e = 1`` its in-window losses are
      counted as inter-frame (gap) errors; rollsim keeps them as decode
      errors. The outcome (lost) is the same.
    * **Stop condition.** The paper caps a run at 50000 emissions. The
      published ``Simulation.java`` passes the clock (``duration100Us``, in
      100 us) to its stop test instead of the emission count, with ``>``:
      50000 would stop after 5 s of simulated time (about 770 PHY-SDUs of
      6.5 ms). rollsim caps emissions, as the paper says, with ``>=``, and
      a capped run has goodput 0 (paper §6.3.1). Where the visible part of
      the frame cannot hold a PHY-SDU (``visible_slots <= sdu_slots``: from
      32.5 cm on with the paper's link) nothing is ever received and every
      run is capped.
    * Only the RP strategy exists in CamComSim 1.0; RS is rollsim's
      addition.
    """

    frame_slots: int
    visible_slots: int
    sdu_slots: int
    p_e: float

    kind = "camcomsim"
    notes = (
        "camcomsim: the message is G bytes in ceil(8 G / P) packets, as on every channel; CamComSim's own "
        "generation size G counted packets (its G = 1000 is 1000 packets, here 422 of 19 bits)",
        "camcomsim: the clock advances by the PHY-SDU duration only, not by the random 0..9 slot gap "
        "between emissions",
    )

    def __post_init__(self):
        object.__setattr__(self, "frame_slots", _as_count(self.frame_slots, "frame_slots", 1))
        object.__setattr__(self, "visible_slots", _as_count(self.visible_slots, "visible_slots"))
        object.__setattr__(self, "sdu_slots", _as_count(self.sdu_slots, "sdu_slots", 1))
        object.__setattr__(self, "p_e", _as_probability(self.p_e, "p_e"))

    @classmethod
    def from_parameters(
        cls,
        frame_period_ms: float = 33.3,
        ifg_ratio: float = 0.1,
        distance_cm: float = 5.0,
        p_e: float = 0.001,
        header_bits: int = 5,
        payload_bits: int = 19,
        clock_hz: float = 8000.0,
        line_code: str = "manchester",
        *,
        java_float32: bool = False,
    ) -> "CamcomsimChannel":
        """The channel from CamComSim's parameters (defaults: paper §6.3, Table 1).

        Parameters
        ----------
        frame_period_ms : float
            Frame period in ms; take it as CamComSim users give it (33.3),
            see :func:`camcomsim_visible_slots` for the ``1000/30`` trap.
        ifg_ratio : float
            Inter-frame gap ratio, in [0, 1].
        distance_cm : float
            Distance in cm, >= 0.
        p_e : float
            Decode error probability.
        header_bits, payload_bits : int
            ``H`` and ``P`` in bits.
        clock_hz : float
            Chip rate in Hz.
        line_code : {'manchester', '4b6b'}
        java_float32 : bool, default False
            Reproduce CamComSim's float32 rounding of the frame and PHY-SDU
            durations bit for bit instead of the robust arithmetic.
        """
        return cls(
            frame_slots=camcomsim_frame_slots(frame_period_ms, java_float32=java_float32),
            visible_slots=camcomsim_visible_slots(frame_period_ms, ifg_ratio, distance_cm, java_float32=java_float32),
            sdu_slots=camcomsim_sdu_slots(header_bits, payload_bits, clock_hz, line_code, java_float32=java_float32),
            p_e=p_e,
        )

    @property
    def emission_duration_s(self) -> float:
        return self.sdu_slots * CAMCOMSIM_SLOT_S

    @property
    def emission_duration_100us(self) -> float:
        # Whole slots, exactly (the base's division could round).
        return float(self.sdu_slots)

    @property
    def window_probability(self) -> float:
        """Probability that one emission is inside the window.

        The start slot is uniform and the increments independent, so every
        emission's slot is exactly uniform on ``[0, frame_slots)``.
        """
        return max(0, min(self.visible_slots - self.sdu_slots, self.frame_slots)) / self.frame_slots

    def parameters(self) -> dict:
        return {
            "kind": self.kind,
            "frame_slots": self.frame_slots,
            "visible_slots": self.visible_slots,
            "sdu_slots": self.sdu_slots,
            "p_e": self.p_e,
            "slot_s": CAMCOMSIM_SLOT_S,
        }

    def open_run(self, seed_sequence: np.random.SeedSequence) -> "_CamcomsimRun":
        """Start one broadcast: draw the start slot from ``seed_sequence``."""
        return _CamcomsimRun(self, np.random.default_rng(seed_sequence))


class _CamcomsimRun:
    def __init__(self, channel: CamcomsimChannel, rng: np.random.Generator):
        self._ch = channel
        self._rng = rng
        self._slot = int(rng.integers(channel.frame_slots))
        # An emission is in the window iff its slot < visible - duration.
        self._last_start = channel.visible_slots - channel.sdu_slots

    def next_block(self, count: int) -> np.ndarray:
        ch = self._ch
        increments = self._rng.integers(ch.sdu_slots, ch.sdu_slots + 10, size=count, dtype=np.int64)
        slots = camcomsim_slot_sequence(self._slot, increments, ch.frame_slots)
        self._slot = int(slots[-1]) if count else self._slot
        return _outcomes(slots < self._last_start, self._rng.random(count), ch.p_e)
