"""Channel layer: exact MMBP, Gilbert-Elliott and periodic-channel analysis, and the event simulator.

:mod:`rollsim.channel.analytic` holds the closed forms, checked against
enumeration; :mod:`rollsim.channel.periodic` the exact figures of a cycle
of slots each with its own success probability (the MMBP, and the
position model's slot profiles from :mod:`rollsim.channel.position`);
:mod:`rollsim.channel.eventsim` broadcasts messages over the ``mmbp``,
``timed`` and ``camcomsim`` channels of :mod:`rollsim.channel.channels`,
the ``periodic`` channel and the Gilbert-Elliott channel of
:mod:`rollsim.channel.markov`; :mod:`rollsim.channel.scene_channel` builds
the first three from a scene.
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
from rollsim.channel.markov import GeChannel
from rollsim.channel.periodic import PeriodicChannel, PeriodicFigures, exact_figures, goodput_bps
from rollsim.channel.periodic_rlnc import rlnc_periodic_figures, rlnc_replay_goodput_bps
from rollsim.channel.position import SlotProfiles, slot_profiles
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
    "GeChannel",
    "METRICS",
    "MmbpChannel",
    "PeriodicChannel",
    "PeriodicFigures",
    "RECEIVED",
    "SceneBroadcast",
    "SlotProfiles",
    "TimedChannel",
    "broadcast_from_scene",
    "camcomsim_frame_slots",
    "camcomsim_roi",
    "camcomsim_sdu_slots",
    "camcomsim_visible_slots",
    "capture_window_from_scene",
    "channel_from_scene",
    "exact_figures",
    "goodput_bps",
    "rlnc_periodic_figures",
    "rlnc_replay_goodput_bps",
    "run_seed_sequence",
    "simulate_broadcast",
    "simulate_scene",
    "slot_profiles",
    "summarize",
    "summary_statistics",
    "to_camcomsim",
]
