"""Map a scene to the event simulator's channel, schedule and packet format.

=============  ==============================================================
kind           scene fields used
=============  ==============================================================
``mmbp``       ``channel.M``, ``channel.N`` (or, when both are null, M and N
               derived from the physics, see :func:`mmbp_slots_from_scene`),
               ``channel.p_e``, the PHY-SDU duration
``timed``      ``camera.frame_rate_hz``, the capture window
               (:func:`capture_window_from_scene`), the PHY-SDU duration,
               ``channel.p_e``, ``channel.frame_jitter_us``
``camcomsim``  ``camera.frame_rate_hz`` (as ms), ``camera.ifg_ratio`` (or the
               effective ratio when the scene gives ``row_time_us``),
               ``link.distance_cm``, ``channel.p_e``, ``link.header_bits``,
               ``link.payload_bits``, ``link.clock_hz``, ``link.line_code``
=============  ==============================================================

The PHY-SDU duration of ``mmbp`` and ``timed`` is rollsim's,
``PhyFormat(H, P, check, line_code).sdu_duration_s(clock_hz)`` (SYNC and
check bits included); ``camcomsim`` uses CamComSim's own formula.

The message: ``mmbp`` and ``timed`` send ``ceil(8 G / P)`` packets of a
``G = link.message_bytes`` byte message, as the transmitter does;
``camcomsim`` reads ``link.message_bytes`` as CamComSim's generation size,
which counts **packets** (the result's notes say so).
"""

from __future__ import annotations

from dataclasses import dataclass

from rollsim.channel.analytic import MmbpSlots, mmbp_slots_from_physics
from rollsim.channel.channels import CamcomsimChannel, MmbpChannel, TimedChannel
from rollsim.channel.eventsim import DEFAULT_MAX_EMISSIONS, BroadcastResult, simulate_broadcast
from rollsim.optics.geometry import led_rows
from rollsim.protocol.packets import n_packets as packets_of_message
from rollsim.transmitter.schedule import Schedule
from rollsim.transmitter.transmitter import phy_from_scene

__all__ = [
    "CHANNEL_KINDS",
    "SceneBroadcast",
    "broadcast_from_scene",
    "capture_window_from_scene",
    "channel_from_scene",
    "led_row_count",
    "mmbp_slots_from_scene",
    "sdu_duration_from_scene",
    "simulate_scene",
]

CHANNEL_KINDS = ("mmbp", "timed", "camcomsim")


def _check_kind(kind) -> str:
    if kind not in CHANNEL_KINDS:
        raise ValueError(f"kind must be one of {list(CHANNEL_KINDS)}, got {kind!r}")
    return kind


def sdu_duration_from_scene(scene) -> float:
    """Duration of one PHY-SDU in seconds (SYNC, coded header, payload, check)."""
    return phy_from_scene(scene).sdu_duration_s(scene.link.clock_hz)


def led_row_count(scene) -> int:
    """Number of frame rows the LED footprint touches (0 if it misses the frame)."""
    first, last = led_rows(scene)
    return max(0, last - first + 1)


def capture_window_from_scene(scene) -> float:
    """Capture window per frame, seconds: ``rows x row_time + exposure``.

    The LED's rows start one row time apart; the last one integrates for one
    exposure after it starts. An LED that touches no row is never captured
    (window 0, not the bare exposure).
    """
    rows = led_row_count(scene)
    if rows == 0:
        return 0.0
    return rows * scene.camera.row_time_s + scene.camera.exposure_s


def mmbp_slots_from_scene(scene) -> MmbpSlots:
    """MMBP ``(M, N)`` of a scene: given, or derived from its physics.

    With ``channel.M`` and ``channel.N`` both null,
    :func:`rollsim.channel.analytic.mmbp_slots_from_physics` rounds the
    frame period ``T_f`` and the whole PHY-SDUs per capture window
    ``W / T_p - 1`` to integer slots. With both given they are used as they
    are (``mean_whole_sdus_per_frame`` is then ``M``).
    """
    M, N = scene.channel.M, scene.channel.N
    if M is None and N is None:
        return mmbp_slots_from_physics(
            scene.camera.frame_period_s, capture_window_from_scene(scene), sdu_duration_from_scene(scene)
        )
    if M is None or N is None:
        raise ValueError("scene channel.M and channel.N: give both, or neither to derive them from the physics")
    if M + N < 1:
        raise ValueError(f"scene channel.M + channel.N must be >= 1, got M = {M}, N = {N}")
    return MmbpSlots(M=M, N=N, cycle_slots=M + N, mean_whole_sdus_per_frame=float(M))


def channel_from_scene(scene, kind: str, *, java_float32: bool = False):
    """The event simulator's channel of kind ``kind`` for ``scene``.

    Parameters
    ----------
    scene : rollsim.scene.Scene
    kind : {'mmbp', 'timed', 'camcomsim'}
    java_float32 : bool, default False
        ``camcomsim`` only: reproduce CamComSim's float32 rounding (see
        :meth:`rollsim.channel.channels.CamcomsimChannel.from_parameters`).

    Returns
    -------
    MmbpChannel, TimedChannel or CamcomsimChannel
    """
    kind = _check_kind(kind)
    p_e = scene.channel.p_e
    if kind == "mmbp":
        slots = mmbp_slots_from_scene(scene)
        return MmbpChannel(M=slots.M, N=slots.N, p_e=p_e, sdu_duration_s=sdu_duration_from_scene(scene))
    if kind == "timed":
        return TimedChannel(
            frame_period_s=scene.camera.frame_period_s,
            capture_window_s=capture_window_from_scene(scene),
            sdu_duration_s=sdu_duration_from_scene(scene),
            p_e=p_e,
            frame_jitter_s=scene.channel.frame_jitter_us * 1e-6,
        )
    camera, link = scene.camera, scene.link
    ifg = camera.ifg_ratio if camera.ifg_ratio is not None else camera.ifg_ratio_effective
    return CamcomsimChannel.from_parameters(
        frame_period_ms=camera.frame_period_s * 1e3,
        ifg_ratio=min(max(ifg, 0.0), 1.0),  # the effective ratio may leave [0, 1] by an ulp
        distance_cm=link.distance_cm,
        p_e=p_e,
        header_bits=link.header_bits,
        payload_bits=link.payload_bits,
        clock_hz=link.clock_hz,
        line_code=link.line_code,
        java_float32=java_float32,
    )


@dataclass(frozen=True)
class SceneBroadcast:
    """Everything :func:`rollsim.channel.eventsim.simulate_broadcast` needs from a scene."""

    channel: object
    schedule: Schedule
    header_bits: int
    payload_bits: int


def broadcast_from_scene(scene, kind: str, *, java_float32: bool = False) -> SceneBroadcast:
    """Channel, schedule (strategy, packets, repeats) and ``H``, ``P`` of a scene.

    ``camcomsim`` reads ``link.message_bytes`` as a number of packets
    (CamComSim's generation size); the other kinds cut the message into
    ``ceil(8 G / P)`` packets.
    """
    kind = _check_kind(kind)
    link = scene.link
    n = link.message_bytes if kind == "camcomsim" else packets_of_message(link.message_bytes, link.payload_bits)
    return SceneBroadcast(
        channel=channel_from_scene(scene, kind, java_float32=java_float32),
        schedule=Schedule(link.strategy, n, link.repeats),
        header_bits=link.header_bits,
        payload_bits=link.payload_bits,
    )


def simulate_scene(
    scene,
    kind: str,
    *,
    runs: int = 1000,
    seed=None,
    max_emissions: int = DEFAULT_MAX_EMISSIONS,
    workers=None,
    progress=None,
    java_float32: bool = False,
) -> BroadcastResult:
    """Simulate the scene's broadcast over the channel ``kind``.

    ``seed`` defaults to the scene's seed. Other parameters as in
    :func:`rollsim.channel.eventsim.simulate_broadcast`.
    """
    setup = broadcast_from_scene(scene, kind, java_float32=java_float32)
    return simulate_broadcast(
        setup.channel,
        setup.schedule,
        header_bits=setup.header_bits,
        payload_bits=setup.payload_bits,
        runs=runs,
        seed=scene.seed if seed is None else seed,
        max_emissions=max_emissions,
        workers=workers,
        progress=progress,
    )
