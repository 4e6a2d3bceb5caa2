"""What the physics and the MMBP analysis predict for a scene's link.

One place for the figures that ``rollsim describe`` prints and the sweeps'
``analytic`` stage tabulates: the LED's rows and the ROI ratio, the MMBP
``(M, N)`` derived from them, and p0, P(message) and the expected goodput
of RP and RS, and the expected emissions and goodput of random linear
coding (rlnc). No rendering: geometry and closed forms only.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

from rollsim.channel import analytic, rateless
from rollsim.channel.scene_channel import (
    capture_window_from_scene,
    mmbp_slots_from_scene,
    sdu_duration_from_scene,
    scene_led_rows,
)
from rollsim.protocol.packets import n_packets
from rollsim.protocol.rlnc import seed_space as rateless_seed_space

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

__all__ = ["link_prediction", "mmbp_figures"]


@functools.lru_cache(maxsize=1 << 16)
def _cached_figures(M: int, N: int, r: int, p_e: float, n: int, payload_bits: int, sdu_s: float) -> dict:
    figures = {"p0_rp": analytic.mmbp_p0_rp(M, N, r, p_e), "p0_rs": analytic.mmbp_p0_rs(M, N, r, p_e, n)}
    for strategy in ("rp", "rs"):
        figures[f"p_message_{strategy}"] = analytic.mmbp_p_message(M, N, r, p_e, n, strategy)
        figures[f"goodput_{strategy}_bps"] = analytic.mmbp_expected_goodput_bps(M, N, r, p_e, n, strategy,
                                                                                payload_bits, sdu_s)
    return figures


@functools.lru_cache(maxsize=1 << 16)
def _cached_rlnc_figures(M: int, N: int, p_e: float, n: int, payload_bits: int, sdu_s: float) -> dict:
    expected, goodput = rateless.rlnc_figures(M, N, p_e, n, payload_bits, sdu_s)
    return {"expected_emissions_rlnc": expected, "goodput_rlnc_bps": goodput}


def mmbp_figures(M: int, N: int, r: int, p_e: float, n: int, payload_bits: int, sdu_s: float,
                 rlnc: bool = True) -> dict:
    """p0, P(message) and expected goodput (bit/s) of RP and RS under the MMBP, and rlnc's figures.

    Keys ``p0_rp``, ``p0_rs``, ``p_message_rp``, ``goodput_rp_bps``,
    ``p_message_rs``, ``goodput_rs_bps`` and, with ``rlnc``,
    ``expected_emissions_rlnc`` and ``goodput_rlnc_bps``. Memoised (a sweep
    over distance or exposure meets the same few ``(M, N)`` in thousands of
    cells); the dict returned is a fresh copy.

    Parameters
    ----------
    M, N : int
        MMBP ON and OFF slots per cycle.
    r : int
        Repeats.
    p_e : float
        PHY-SDU error probability inside the window.
    n : int
        Packets of the message.
    payload_bits : int
        P, bits.
    sdu_s : float
        PHY-SDU duration, s.
    rlnc : bool, default True
        Include random linear coding's figures. Their negative binomial is
        scipy.special's, whose import costs about 0.3 s: a caller that
        shows only RP or RS (``rollsim describe``'s text) leaves them out.
    """
    figures = dict(_cached_figures(int(M), int(N), int(r), float(p_e), int(n), int(payload_bits), float(sdu_s)))
    if rlnc:
        figures.update(_cached_rlnc_figures(int(M), int(N), float(p_e), int(n), int(payload_bits), float(sdu_s)))
    return figures


def link_prediction(scene: Scene, rlnc: bool = True) -> dict:
    """The scene's link as the physics and the MMBP analysis see it.

    Parameters
    ----------
    scene : Scene
    rlnc : bool, default True
        Include random linear coding's figures whatever the scene's strategy
        (:func:`mmbp_figures`); an rlnc scene always has them.

    Returns
    -------
    dict
        ``led_rows`` (first and last row of the LED, or None: those its
        geometric image touches or, with ``glare``, those whose stripes clear
        the noise; :func:`rollsim.channel.scene_channel.scene_led_rows`),
        ``led_rows_from`` (which of the two), ``roi_ratio`` (those rows over the frame's), ``roi_ratio_eq10``
        (the paper's Eq. 10 with the LED's size), ``M``, ``N``, ``mn_from``
        ("physics", or "scene" where ``channel.M`` and ``channel.N`` are given),
        ``sdu_duration_s``, ``capture_window_s``, ``n_packets``, ``repeats``,
        ``p_e``, and :func:`mmbp_figures`; ``strategy`` and, for it,
        ``p0``, ``p_message`` and ``goodput_bps``.

    Raises
    ------
    ValueError
        If the scene gives only one of ``channel.M`` and ``channel.N``.
    """
    cam, link, led = scene.camera, scene.link, scene.led
    slots = mmbp_slots_from_scene(scene)
    first, last = scene_led_rows(scene)
    rows = max(0, last - first + 1)
    n, sdu_s = n_packets(link.message_bytes, link.payload_bits), sdu_duration_from_scene(scene)
    sensor_mm = cam.height_px * cam.pixel_pitch_um * 1e-3
    strategy = link.strategy
    figures = mmbp_figures(slots.M, slots.N, link.repeats, scene.channel.p_e, n, link.payload_bits, sdu_s,
                           rlnc=rlnc or strategy == "rlnc")
    return {
        "led_rows": [int(first), int(last)] if rows else None,
        "led_rows_from": "geometric image" if "glare" not in scene.effects else "stripes above the noise",
        "roi_ratio": rows / cam.height_px,
        "roi_ratio_eq10": analytic.roi_ratio(link.distance_cm * 10.0, led.size_mm, cam.focal_length_mm, sensor_mm),
        "M": slots.M, "N": slots.N, "mn_from": "physics" if scene.channel.M is None else "scene",
        "sdu_duration_s": sdu_s, "capture_window_s": capture_window_from_scene(scene),
        "n_packets": n, "repeats": link.repeats, "p_e": scene.channel.p_e,
        **figures,
        "strategy": strategy,
        # rlnc has no per-packet loss or one-round message probability: its
        # figure is the expected emissions until rank K.
        "p0": figures.get(f"p0_{strategy}"),
        "p_message": figures.get(f"p_message_{strategy}"),
        "goodput_bps": figures[f"goodput_{strategy}_bps"],
        "seed_space": rateless_seed_space(link.header_bits) if strategy == "rlnc" else None,
    }
