"""Channel layer: exact MMBP and Gilbert-Elliott analysis, and the event simulator.

:mod:`rollsim.channel.analytic` holds the closed forms, checked against
enumeration; :mod:`rollsim.channel.eventsim` broadcasts messages over the
``mmbp``, ``timed`` and ``camcomsim`` channels of
:mod:`rollsim.channel.channels`; :mod:`rollsim.channel.scene_channel` builds
them from a scene.
"""

from rollsim.channel.channels import (
    CAMCOMSIM_ROI_TABLE,
    DECODE_ERROR,
    GAP_LOSS,
    RECEIVED,
    CamcomsimChannel,
    MmbpChannel,
    TimedChannel,
    camcomsim_frame_slots,
    camcomsim_roi,
    camcomsim_sdu_slots,
    camcomsim_visible_slots,
)
from rollsim.channel.eventsim import (
    CAMCOMSIM_FIELDS,
    DEFAULT_MAX_EMISSIONS,
    METRICS,
    BroadcastResult,
    run_seed_sequence,
    simulate_broadcast,
    summarize,
    summary_statistics,
    to_camcomsim,
)
from rollsim.channel.scene_channel import (
    CHANNEL_KINDS,
    SceneBroadcast,
    broadcast_from_scene,
    capture_window_from_scene,
    channel_from_scene,
    simulate_scene,
)

__all__ = [
    "BroadcastResult",
    "CAMCOMSIM_FIELDS",
    "CAMCOMSIM_ROI_TABLE",
    "CHANNEL_KINDS",
    "CamcomsimChannel",
    "DECODE_ERROR",
    "DEFAULT_MAX_EMISSIONS",
    "GAP_LOSS",
    "METRICS",
    "MmbpChannel",
    "RECEIVED",
    "SceneBroadcast",
    "TimedChannel",
    "broadcast_from_scene",
    "camcomsim_frame_slots",
    "camcomsim_roi",
    "camcomsim_sdu_slots",
    "camcomsim_visible_slots",
    "capture_window_from_scene",
    "channel_from_scene",
    "run_seed_sequence",
    "simulate_broadcast",
    "simulate_scene",
    "summarize",
    "summary_statistics",
    "to_camcomsim",
]
