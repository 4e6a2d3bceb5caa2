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

The message: every kind sends ``N_p = ceil(8 G / P)`` packets of a
``G = link.message_bytes`` byte message, as the transmitter does.
(CamComSim's own generation size counts packets: its ``G = 1000`` is 1000
packets, rollsim's is 422 of 19 bits.)

Scene rules the ``camcomsim`` channel does not depend on
(:func:`scene_relaxations`, for ``load_scene(..., relax=...)``):

* too few header bits for the packets, 0 included: CamComSim tells packets
  apart by identity, not by sequence number, so its header length only
  lengthens the PHY-SDU and the numbers may wrap (a warning says so);
* a distance from 0 up to the focal length: its ROI comes from the measured
  table (``distance_cm = 0`` is ROI 1), never from the thin lens.

The ``mmbp`` and ``timed`` channels refuse scenes that need either.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rollsim.channel.analytic import MmbpSlots, mmbp_slots_from_physics
from rollsim.channel.channels import CamcomsimChannel, MmbpChannel, TimedChannel, camcomsim_roi
from rollsim.channel.eventsim import (
    DEFAULT_MAX_EMISSIONS,
    BroadcastResult,
    check_broadcast_memory,
    default_event_workers,
    simulate_broadcast,
)
from rollsim.optics.geometry import led_rows
from rollsim.protocol.packets import n_packets as packets_of_message
from rollsim.scene.loader import DISTANCE_WITHOUT_LENS, SEQUENCE_WRAP, relaxations_used
from rollsim.transmitter.schedule import RlncSchedule, Schedule, schedule_for
from rollsim.transmitter.transmitter import phy_from_scene

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

__all__ = [
    "CHANNEL_KINDS",
    "SceneBroadcast",
    "broadcast_from_scene",
    "camcomsim_parameters",
    "capture_window_from_scene",
    "channel_from_scene",
    "led_row_count",
    "mmbp_slots_from_scene",
    "scene_relaxations",
    "sdu_duration_from_scene",
    "simulate_scene",
]

CHANNEL_KINDS = ("mmbp", "timed", "camcomsim")
# Scene rules each kind does without (see the module docstring).
_RELAXATIONS = {"mmbp": (), "timed": (), "camcomsim": (SEQUENCE_WRAP, DISTANCE_WITHOUT_LENS)}
# rollsim names -> CamComSim's enum names (AbstractStrategy.Strategy, Led.Rll), spelling kept.
_CAMCOMSIM_STRATEGY = {"rp": "REPEAT_PACKET_STRATEGY", "rs": "REPEAT_SEQUENCE_STRAEGY"}
_CAMCOMSIM_RLL = {"manchester": "RLL_MANCHESTER", "4b6b": "RLL_4B6B"}


def _check_kind(kind) -> str:
    if kind not in CHANNEL_KINDS:
        raise ValueError(f"kind must be one of {list(CHANNEL_KINDS)}, got {kind!r}")
    return kind


def scene_relaxations(kind: str) -> tuple[str, ...]:
    """Scene rules the channel ``kind`` does not depend on.

    Pass them to :func:`rollsim.scene.load_scene` (``relax=``) to load a
    scene for this channel only: ``camcomsim`` does without
    :data:`~rollsim.scene.loader.SEQUENCE_WRAP` and
    :data:`~rollsim.scene.loader.DISTANCE_WITHOUT_LENS`; ``mmbp`` and
    ``timed`` need every rule (empty tuple).
    """
    return _RELAXATIONS[_check_kind(kind)]


def _ifg_ratio_for_camcomsim(camera) -> float:
    ifg = camera.ifg_ratio if camera.ifg_ratio is not None else camera.ifg_ratio_effective
    return min(max(ifg, 0.0), 1.0)  # the effective ratio may leave [0, 1] by an ulp


def sdu_duration_from_scene(scene: Scene) -> float:
    """Duration of one PHY-SDU in seconds (SYNC, coded header, payload, check)."""
    return phy_from_scene(scene).sdu_duration_s(scene.link.clock_hz)


def scene_led_rows(scene: Scene) -> tuple[int, int]:
    """First and last row of the scene's LED (``last < first`` if none).

    The rows its geometric image touches
    (:func:`rollsim.optics.geometry.led_rows`), or, with ``glare``, whose
    halo reaches every row, the rows whose stripes clear the noise
    (:func:`rollsim.effects.readable.readable_rows`, computed once per scene).
    """
    if "glare" not in scene.effects:
        return led_rows(scene)
    # Keyed on what the rows depend on: a sweep over p_e or the strategy
    # computes them once.
    key = scene.model_copy(update={"name": "", "description": "", "channel": type(scene.channel)(),
                                   "link": type(scene.link)(distance_cm=scene.link.distance_cm)})
    return _readable_rows(type(key), key.model_dump_json())


@functools.lru_cache(maxsize=64)
def _readable_rows(model: type[Scene], scene_json: str) -> tuple[int, int]:
    from rollsim.render_contract.setup import build_setup  # here: the glare's setup is the renderer's
    from rollsim.render.stages import prepare_setup

    rows = prepare_setup(build_setup(model.model_validate_json(scene_json))).led_rows
    return rows if rows else (0, -1)


def led_row_count(scene: Scene) -> int:
    """Number of frame rows of the scene's LED (0 if none; :func:`scene_led_rows`)."""
    first, last = scene_led_rows(scene)
    return max(0, last - first + 1)


def capture_window_from_scene(scene: Scene) -> float:
    """Capture window per frame, seconds: ``rows x row_time + exposure``.

    The LED's rows start one row time apart; the last one integrates for one
    exposure after it starts. An LED that touches no row is never captured
    (window 0, not the bare exposure).
    """
    rows = led_row_count(scene)
    if rows == 0:
        return 0.0
    return rows * scene.camera.row_time_s + scene.camera.exposure_s


def mmbp_slots_from_scene(scene: Scene) -> MmbpSlots:
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


def channel_from_scene(scene: Scene, kind: str, *, java_float32: bool = False):
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
    return CamcomsimChannel.from_parameters(
        frame_period_ms=camera.frame_period_s * 1e3,
        ifg_ratio=_ifg_ratio_for_camcomsim(camera),
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
    """Everything :func:`rollsim.channel.eventsim.simulate_broadcast` needs from a scene.

    ``warnings`` are one-line caveats of this scene on this channel (sequence
    numbers that wrap, a link that never receives), for the user to see
    before the runs.
    """

    channel: object
    schedule: Schedule | RlncSchedule
    header_bits: int
    payload_bits: int
    warnings: tuple = ()


def _refuse_relaxed(scene: Scene, kind: str) -> None:
    """Refuse a scene loaded with relaxations that ``kind`` does not grant."""
    link, focal_mm = scene.link, scene.camera.focal_length_mm
    needed = [rule for rule in relaxations_used(scene) if rule not in _RELAXATIONS[kind]]
    if SEQUENCE_WRAP in needed:
        packets = packets_of_message(link.message_bytes, link.payload_bits)
        raise ValueError(
            f"link.header_bits = {link.header_bits}: too few for {packets} packets; only the camcomsim channel "
            "lets sequence numbers wrap"
        )
    if DISTANCE_WITHOUT_LENS in needed:
        raise ValueError(
            f"link.distance_cm = {link.distance_cm:g}: not farther than the focal length ({focal_mm:g} mm), where "
            "the thin lens diverges; only the camcomsim channel, which uses its measured ROI table, accepts it"
        )


def _camcomsim_warnings(scene: Scene, channel: CamcomsimChannel, n_packets: int) -> tuple[str, ...]:
    link, warnings = scene.link, []
    if SEQUENCE_WRAP in relaxations_used(scene):
        numbers = 2**link.header_bits
        warnings.append(
            f"link.header_bits = {link.header_bits}: {numbers} sequence number{'s' if numbers > 1 else ''} for "
            f"{n_packets} packets, so they wrap; the camcomsim channel tells the packets apart anyway, as CamComSim "
            "does, which a real receiver could not"
        )
    if channel.window_probability == 0.0:
        warnings.append(
            f"link.distance_cm = {link.distance_cm:g}: the camcomsim channel never receives: {channel.visible_slots} "
            f"visible slots per frame (ROI {camcomsim_roi(link.distance_cm):.3g}) cannot hold a PHY-SDU of "
            f"{channel.sdu_slots} slots, so every run will reach the emission cap"
        )
    return tuple(warnings)


def broadcast_from_scene(scene: Scene, kind: str, *, java_float32: bool = False) -> SceneBroadcast:
    """Channel, schedule (strategy, packets, repeats) and ``H``, ``P`` of a scene.

    Every kind cuts the ``G = link.message_bytes`` byte message into
    ``ceil(8 G / P)`` packets.

    Raises
    ------
    ValueError
        ``camcomsim`` with ``link.strategy = 'rs'`` (CamComSim has only RP);
        ``mmbp`` or ``timed`` with a scene that needs a relaxation only
        ``camcomsim`` grants (see :func:`scene_relaxations`).
    """
    kind = _check_kind(kind)
    link = scene.link
    _refuse_relaxed(scene, kind)
    if kind == "camcomsim" and link.strategy != "rp":
        raise ValueError(
            f"link.strategy = {link.strategy!r}: CamComSim has only the RP strategy, so the camcomsim channel does "
            "too; use --channel mmbp or timed for RS and rlnc"
        )
    n = packets_of_message(link.message_bytes, link.payload_bits)
    channel = channel_from_scene(scene, kind, java_float32=java_float32)
    return SceneBroadcast(
        channel=channel,
        schedule=schedule_for(link.strategy, n, link.repeats, link.header_bits),
        header_bits=link.header_bits,
        payload_bits=link.payload_bits,
        warnings=_camcomsim_warnings(scene, channel, n) if kind == "camcomsim" else (),
    )


def _whole_or_float(value: float):
    """``value`` as an int when whole (CamComSim's ``int`` fields), else as it is."""
    return int(value) if float(value).is_integer() else float(value)


def camcomsim_parameters(scene: Scene, result: BroadcastResult, *, save_path: str = "./", verbose: int = 1) -> dict:
    """CamComSim's ``simuParams`` of a simulated scene: every field it writes, in its order.

    Parameters
    ----------
    scene : rollsim.scene.Scene
        The scene simulated.
    result : BroadcastResult
        Its result: runs, cap, strategy, repeats, ``H`` and ``P``.
    save_path : str, default "./"
        ``savePath``: the directory the results are written to.
    verbose : int, default 1
        ``verbose``: CamComSim's verbosity level (0 quiet, 1 its default).

    Returns
    -------
    dict
        ``simuGenerationSizeByte`` (G, bytes: rollsim's meaning, which
        CamComSim's name gives but its code reads as packets),
        ``simuScenario`` ("TestScenario", the scenario rollsim reproduces),
        ``simuStrategy`` ("REPEAT_PACKET_STRATEGY" or
        "REPEAT_SEQUENCE_STRAEGY", CamComSim's spelling),
        ``simuNbRepeatPhysdu`` (r), ``simuNbIteration`` (runs),
        ``camFrameIntervalMs`` (ms), ``camIFGRatio``, ``camPDecodeError``,
        ``chanDistanceCm`` (cm; an int when whole, as CamComSim's field),
        ``physduMaxLen`` (0: CamComSim never sets it), ``physduPayloadLen``
        and ``physduHeaderLen`` (bits), ``ledTxFreqHz`` (Hz; an int when
        whole), ``ledRll`` ("RLL_MANCHESTER" or "RLL_4B6B"), ``saveResult``
        (true: the results were saved), ``savePath``, ``verbose`` and
        ``stopCondition`` (CamComSim's syntax: ``"<cap>X"``, stop at the
        cap or when the message is complete; rollsim's cap counts
        emissions).
    """
    camera, link = scene.camera, scene.link
    return {
        "simuGenerationSizeByte": link.message_bytes,
        "simuScenario": "TestScenario",
        "simuStrategy": _CAMCOMSIM_STRATEGY[result.strategy],
        "simuNbRepeatPhysdu": result.repeats,
        "simuNbIteration": result.runs,
        "camFrameIntervalMs": camera.frame_period_s * 1e3,
        "camIFGRatio": _ifg_ratio_for_camcomsim(camera),
        "camPDecodeError": scene.channel.p_e,
        "chanDistanceCm": _whole_or_float(link.distance_cm),
        "physduMaxLen": 0,
        "physduPayloadLen": result.payload_bits,
        "physduHeaderLen": result.header_bits,
        "ledTxFreqHz": _whole_or_float(link.clock_hz),
        "ledRll": _CAMCOMSIM_RLL[link.line_code],
        "saveResult": True,
        "savePath": save_path,
        "verbose": verbose,
        "stopCondition": f"{result.max_emissions}X",
    }


def check_runs_first(scene: Scene, runs, workers=None, max_emissions: int = DEFAULT_MAX_EMISSIONS,
                     record_loss_streaks: bool = False) -> None:
    """Refuse too many runs before the scene's channel is built (which may
    render the LED's glare): a clear error, at once, even under a tight limit.
    Invalid ``runs`` or ``workers`` are left to the simulation's own checks."""
    if isinstance(runs, int) and runs >= 1 and (workers is None or isinstance(workers, int) and workers >= 1):
        n = packets_of_message(scene.link.message_bytes, scene.link.payload_bits)
        check_broadcast_memory(runs, n, default_event_workers() if workers is None else workers,
                               max_emissions, record_loss_streaks)


def simulate_scene(
    scene: Scene,
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
    check_runs_first(scene, runs, workers, max_emissions)
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
