"""A plain-text and JSON summary of a scene's timing, PHY-SDU, schedule, link prediction and signal budget."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from rollsim.plumbing.budget import check_memory
from rollsim.channel.prediction import link_prediction
from rollsim.optics.geometry import led_image_size_px
from rollsim.optics.radiometry import photon_rate_per_pixel, photons_per_lumen_illuminant, photons_per_lumen_monochromatic
from rollsim.optics.scene_light import ambient_sensor_illuminances_lx, led_sensor_illuminance_lx
from rollsim.protocol import camcomsim_sdu_duration_s, last_payload_bits
from rollsim.sensor.adc import full_scale_electrons
from rollsim.transmitter import transmitter_from_scene

if TYPE_CHECKING:
    from rollsim.scene.model import Scene


def _chip_string(chips) -> str:
    return "".join("#" if c else "." for c in np.asarray(chips).ravel())


def describe_scene(scene: Scene, emissions: int = 12, rlnc: bool = True) -> dict:
    """Key figures of a scene, as a JSON-ready dict.

    Parameters
    ----------
    scene : Scene
    emissions : int
        How many emissions of the schedule to list.
    rlnc : bool, default True
        Predict random linear coding's figures for a scene of another
        strategy too (:func:`rollsim.channel.prediction.link_prediction`);
        :func:`format_description` shows only the scene's own strategy.
    """
    cam, link = scene.camera, scene.link
    # The listed sequence numbers become an int64, a Python int and JSON
    # text each: about 64 bytes per emission.
    check_memory(f"--emissions = {emissions}", 64 * emissions)
    tx = transmitter_from_scene(scene)
    phy = tx.phy
    round_emissions = tx.schedule.emissions_per_round
    ones = tx.waveform.chips.ones_before(np.array([0, round_emissions * phy.sdu_chips]))
    return {
        "name": scene.name,
        "camera": {
            "preset": cam.preset,
            "width_px": cam.width_px,
            "height_px": cam.height_px,
            "frame_period_ms": cam.frame_period_s * 1e3,
            "row_time_us": cam.row_time_s * 1e6,
            "row_timing_from": "row_time_us" if cam.row_time_us is not None else "ifg_ratio",
            "readout_ms": cam.readout_s * 1e3,
            "ifg_ratio": cam.ifg_ratio_effective,
            "exposure_us": cam.exposure_us,
            "iso": cam.iso,
            "gain_dn_per_e": cam.gain_dn_per_e_at_iso,
        },
        "phy": {
            "line_code": phy.line_code,
            "check": phy.check,
            "header_bits": phy.header_bits,
            "payload_bits": phy.payload_bits,
            "check_bits": phy.check_bits,
            "sync": _chip_string(phy.sync),
            "sdu_chips": phy.sdu_chips,
            "sdu_duration_ms": tx.sdu_duration_s * 1e3,
            "camcomsim_sdu_duration_ms": camcomsim_sdu_duration_s(
                phy.header_bits, phy.payload_bits, link.clock_hz, phy.line_code
            )
            * 1e3,
            "rows_per_chip": 1.0 / (link.clock_hz * cam.row_time_s),
            "sdus_per_frame_period": cam.frame_period_s / tx.sdu_duration_s,
        },
        "message": {
            "bytes": link.message_bytes,
            "packets": tx.n_packets,
            "last_payload_bits": last_payload_bits(link.message_bytes, link.payload_bits),
        },
        "schedule": {
            "strategy": link.strategy,
            "repeats": link.repeats,
            "emissions_per_round": tx.schedule.emissions_per_round,
            "first_sequence_numbers": tx.schedule.sequence_numbers(np.arange(emissions)).tolist(),
            "round_duration_ms": tx.schedule.emissions_per_round * tx.sdu_duration_s * 1e3,
        },
        "waveform": {
            "pattern": link.pattern,
            "clock_hz": link.clock_hz,
            "start_offset_us": link.start_offset_us,
            "first_sdu_chips": _chip_string(tx.waveform.chips.values(np.arange(phy.sdu_chips))),
            "on_fraction": float(ones[1] - ones[0]) / max(1, round_emissions * phy.sdu_chips),
        },
        "link": link_prediction(scene, rlnc=rlnc),
        "signal": signal_budget(scene),
        "effects": list(scene.effects.enabled()),
    }


def signal_budget(scene: Scene) -> dict:
    """Photons and electrons per pixel of one exposure, and the stripes' SNR.

    For a pixel fully covered by the LED in a fully ON row and a fully OFF
    row (the LED's light plus ambient light reflected by its face, when the
    ``ambient`` effect is listed) and for a background pixel, at the
    scene's exposure and on the optical axis, before any noise (the LED's
    face at its mean luminance: ``led_profile`` and ``glare`` move its light
    about, which this does not follow); then the
    ON–OFF gap over the noise σ of a pixel halfway between (shot noise of
    its photo- and dark electrons, read noise, quantisation at the set ISO;
    noise effects not listed add nothing), per pixel and for a row mean over
    the LED's width. Electrons above what the sensor records (the smaller
    of the full well and the ADC's range) are clipped, and said so.

    Returns
    -------
    dict
        ``photons`` and ``electrons`` of ``led_on``, ``led_off`` and
        ``background``; ``dark_e``, ``noise_e``, ``recordable_e``,
        ``clipped``, ``snr_pixel``, ``snr_row`` and ``led_width_px``.
    """
    cam, led = scene.camera, scene.led
    listed = set(scene.effects.enabled())
    t_exp, pitch = cam.exposure_s, cam.pixel_pitch_um * 1e-6
    led_photons = photon_rate_per_pixel(led_sensor_illuminance_lx(scene), pitch,
                                        photons_per_lumen_monochromatic(led.peak_wavelength_nm)) * t_exp
    background_lx, face_lx = ambient_sensor_illuminances_lx(scene)
    ppl = photons_per_lumen_illuminant(scene.environment.ambient_illuminant)
    ambient_on = "ambient" in listed
    background_photons = photon_rate_per_pixel(background_lx, pitch, ppl) * t_exp if ambient_on else 0.0
    face_photons = photon_rate_per_pixel(face_lx, pitch, ppl) * t_exp if ambient_on else 0.0
    # Scalars: scalar illuminances and photons per lumen.
    photons = {"led_on": float(led_photons + face_photons), "led_off": float(led.off_level * led_photons + face_photons),
               "background": float(background_photons)}
    electrons = {key: cam.qe * value for key, value in photons.items()}
    gain = cam.gain_dn_per_e_at_iso
    recordable = min(cam.full_well_e, full_scale_electrons(cam.adc_bits, cam.black_level_dn, gain))
    dark = cam.dark_current_e_per_s * t_exp if "dark_current" in listed else 0.0
    on, off = (min(electrons[key] + dark, recordable) for key in ("led_on", "led_off"))
    variance = 1.0 / (12.0 * gain**2)
    if "shot_noise" in listed:
        variance += 0.5 * (on + off)
    if "read_noise" in listed:
        variance += cam.read_noise_e**2
    noise = math.sqrt(variance)
    width = led_image_size_px(scene)
    return {
        "photons": photons,
        "electrons": electrons,
        "dark_e": float(dark),
        "recordable_e": float(recordable),
        "clipped": bool(electrons["led_on"] + dark > recordable),
        "noise_e": noise,
        "snr_pixel": (on - off) / noise,
        "snr_row": (on - off) / noise * math.sqrt(max(width, 1.0)),
        "led_width_px": float(width),
    }


def format_description(info: dict) -> str:
    """Human-readable text of :func:`describe_scene`'s dict."""
    cam, phy, msg, sch, wave = info["camera"], info["phy"], info["message"], info["schedule"], info["waveform"]
    lines = [
        f"scene      {info['name']}",
        f"camera     {cam['preset'] or '(no preset)'}: {cam['width_px']}x{cam['height_px']} px, "
        f"frame period {cam['frame_period_ms']:.4f} ms",
        f"rows       row time {cam['row_time_us']:.4f} us (from {cam['row_timing_from']}), "
        f"readout {cam['readout_ms']:.4f} ms, IFG ratio {cam['ifg_ratio']:.4f}",
        f"exposure   {cam['exposure_us']:g} us at ISO {cam['iso']:g} (K = {cam['gain_dn_per_e']:.4g} DN/e-)",
        f"PHY-SDU    SYNC {phy['sync']} + {phy['line_code']}(H={phy['header_bits']} | P={phy['payload_bits']} | "
        f"{phy['check']}, {phy['check_bits']} bits) = {phy['sdu_chips']} chips = {phy['sdu_duration_ms']:.4f} ms",
        f"           {phy['rows_per_chip']:.3f} rows per chip, {phy['sdus_per_frame_period']:.3f} PHY-SDUs per frame "
        f"period; CamComSim's formula gives {phy['camcomsim_sdu_duration_ms']:.4f} ms",
        f"message    {msg['bytes']} bytes -> {msg['packets']} packets "
        f"(last payload holds {msg['last_payload_bits']} real bits)",
        f"schedule   {sch['strategy'].upper()} r={sch['repeats']}: round of {sch['emissions_per_round']} emissions "
        f"= {sch['round_duration_ms']:.4g} ms; seq of tx 0..{len(sch['first_sequence_numbers']) - 1}: "
        + " ".join(map(str, sch["first_sequence_numbers"])),
        f"waveform   pattern {wave['pattern']} at {wave['clock_hz']:g} Hz from {wave['start_offset_us']:g} us, "
        f"ON fraction {wave['on_fraction']:.4f}",
        f"           chips of tx 0: {wave['first_sdu_chips']}",
        *_link_lines(info["link"], info["camera"]["height_px"]),
        *_signal_lines(info["signal"]),
        f"effects    {', '.join(info['effects']) or '(none)'}",
    ]
    return "\n".join(lines)


def _link_lines(link: dict, height_px: int) -> list[str]:
    rows = link["led_rows"]
    where = f"rows {rows[0]}-{rows[1]} of {height_px}" if rows else f"no row of {height_px}"
    return [
        f"LED        {where} ({link['led_rows_from']}): ROI ratio {link['roi_ratio']:.3f} "
        f"(the paper's Eq. 10: {link['roi_ratio_eq10']:.3f})",
        f"MMBP       M = {link['M']}, N = {link['N']} from the {link['mn_from']} (capture window "
        f"{link['capture_window_s'] * 1e3:.4g} ms), p_e = {link['p_e']:g}",
        _prediction_line(link),
    ]


def _prediction_line(link: dict) -> str:
    """What the analysis predicts for the scene's strategy."""
    if link["strategy"] == "rlnc":
        return (f"predicted  RLNC, {link['n_packets']} source packets: {link['expected_emissions_rlnc']:.4g} emissions "
                f"expected to decode, expected goodput {link['goodput_bps']:.4g} bit/s (with distinct seeds; "
                f"the header cycles through {link['seed_space']})")
    return (f"predicted  {link['strategy'].upper()} r={link['repeats']}, {link['n_packets']} packets: "
            f"p0 = {link['p0']:.4g}, P(all packets in one round) = {link['p_message']:.4g}, "
            f"expected goodput {link['goodput_bps']:.4g} bit/s")


def _signal_lines(signal: dict) -> list[str]:
    photons, electrons = signal["photons"], signal["electrons"]

    def level(key: str) -> str:
        return f"{photons[key]:.4g} photons, {electrons[key]:.4g} e-"

    clipped = f", clipped at {signal['recordable_e']:.4g} e-" if signal["clipped"] else ""
    return [
        f"signal     per pixel and exposure: LED ON {level('led_on')}{clipped}; OFF {level('led_off')}; "
        f"background {level('background')}; dark {signal['dark_e']:.3g} e-",
        f"           noise {signal['noise_e']:.3g} e- halfway: stripe SNR {signal['snr_pixel']:.3g} per pixel, "
        f"{signal['snr_row']:.3g} for a row's mean over the LED's {signal['led_width_px']:.0f} px",
    ]
