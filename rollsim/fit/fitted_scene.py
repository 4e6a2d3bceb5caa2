"""The scene a camera fit makes: the base scene with the fitted camera, ISP, LED image and ambient light.

What the frames do not show stays the base scene's: the lens and the LED's
distance always; the row noise and column pattern without a background;
the LED's size and place when it fills the frame (it is then made to cover
the frame); the gain and read noise as :func:`rollsim.fit.camera.noise_from_points`
says (:mod:`rollsim.fit.camera`).
"""

from __future__ import annotations

import math

from rollsim.effects.isp_smoothing import MAX_SIGMA_PX
from rollsim.fit.camera import NOT_IDENTIFIED, Estimate, Measured, Parameters, gain_per_full_scale
from rollsim.fit.channel import COLOUR_PLANES
from rollsim.fit.noise import linear_level
from rollsim.fit.tone import scene_tone_curve
from rollsim.scene.model import Scene

# Below these the fit leaves the effect out (a smaller figure is the estimator's noise).
MIN_SMOOTHING_ROWS = 0.3
MIN_GAMMA_CHANGE = 0.05
# An LED that fills the frame is given a disk this many frame diagonals across (it covers the frame).
COVER_DIAGONALS = 1.5
# A frame period this much longer than the readout, where the base scene's is too short.
FRAME_GAP = 1.01
# The fitted well holds this many ADC full scales at least.
FULL_WELL_MARGIN = 1.05
# The scene model's bounds (rollsim.scene.model), which a fit is held to.
MAX_AMBIENT_LUX, MAX_INTENSITY_CD, MAX_LED_SIZE_MM = 1e7, 1e7, 1e4
MAX_PATTERN_E = 1e4  # row_noise's and column_fpn's std_e
# The largest OFF level (a fraction of the ON level) the fit sets.
MAX_OFF_LEVEL = 0.5
# Effects the fit sets or leaves out; the base scene's others are kept.
FITTED_EFFECTS = ("bayer", "tone_curve", "isp_smoothing", "row_noise", "column_fpn", "led_profile", "sharpening", "jpeg",
                  "glare", "video_codec")


def led_disk_px(m: Measured, shape) -> tuple[float, float, float]:
    """The LED's centre (x, y) and diameter, pixels: the fitted disk, or one covering the frame."""
    disk = m.region.disk
    if disk is not None:
        return disk.centre_x_px, disk.centre_y_px, 2.0 * disk.radius_px
    h, w = shape
    return 0.5 * w, 0.5 * h, COVER_DIAGONALS * math.hypot(h, w)


def led_geometry(m: Measured, scene: Scene) -> dict:
    """The LED's place and size as estimates, with their source."""
    x, y, d = led_disk_px(m, (scene.camera.height_px, scene.camera.width_px))
    if m.region.disk is not None:
        return {"led_centre_x_px": Estimate(x, None, "px", "median chord midpoint"),
                "led_centre_y_px": Estimate(y, None, "px", "circle fitted to the chords"),
                "led_diameter_px": Estimate(d, None, "px", "circle fitted to the chords")}
    why = "the LED fills the frame: no edge to place it by; made to cover the frame"
    return {"led_centre_x_px": Estimate(x, None, "px", "the frame's centre", NOT_IDENTIFIED, why),
            "led_centre_y_px": Estimate(y, None, "px", "the frame's centre", NOT_IDENTIFIED, why),
            "led_diameter_px": Estimate(d, None, "px", f"{COVER_DIAGONALS} frame diagonals", NOT_IDENTIFIED, why)}


def plane_response(scene: Scene, plane: str) -> tuple[float, float]:
    """How much of the LED's and of the ambient light's monochrome electron rate a colour plane sees.

    The scene's electron rates (:func:`rollsim.optics.scene_light.led_electron_rate`,
    :func:`rollsim.optics.scene_light.ambient_electron_rates`) take the QE
    at the LED's peak and one photon count per lumen; through the Bayer
    filter each plane sees its channel's integral over the spectrum
    (:mod:`rollsim.optics.spectral`), the render's own rates. ``plane``:
    ``red``, ``green`` or ``blue`` (a grey frame's ``grey``: (1, 1)).

    Returns
    -------
    (led_factor, ambient_factor) : (float, float)
    """
    if plane not in COLOUR_PLANES:
        return 1.0, 1.0
    from rollsim.optics.radiometry import photons_per_lumen_illuminant, photons_per_lumen_monochromatic
    from rollsim.optics.spectral import illuminant_electrons_per_lumen, led_electrons_per_lumen

    bayer, qe = scene.effects.bayer, scene.camera.qe
    c = COLOUR_PLANES.index(plane)
    led = led_electrons_per_lumen(scene.led.peak_wavelength_nm, bayer.led_fwhm_nm, bayer.sensitivities, qe,
                                  bayer.spectral_step_nm)[c]
    illuminant = scene.environment.ambient_illuminant
    ambient = illuminant_electrons_per_lumen(illuminant, bayer.sensitivities, qe, bayer.spectral_step_nm)[c]
    return (float(led) / (qe * photons_per_lumen_monochromatic(scene.led.peak_wavelength_nm)),
            float(ambient) / (qe * photons_per_lumen_illuminant(illuminant)))


def _effects(base_effects: dict, p: Parameters, gamma: float, smoothing: float, profile) -> dict:
    effects = {name: value for name, value in base_effects.items() if name not in FITTED_EFFECTS}
    for name in ("row_noise", "column_fpn"):  # kept from the base scene where the frames give none
        if getattr(p, "row_lin" if name == "row_noise" else "col_lin") is None and name in base_effects:
            effects[name] = base_effects[name]
    effects.update(ambient={}, shot_noise={"method": "poisson"}, read_noise={"method": "table"})
    tone = scene_tone_curve(gamma)
    if tone is not None:
        effects["tone_curve"] = tone
    if smoothing > 0:
        # The scene model's bound: a plane whose stripes barely show can fit a
        # Gaussian wider than any ISP's (the stripe fit allows up to a period).
        effects["isp_smoothing"] = {"sigma_rows_px": round(min(smoothing, MAX_SIGMA_PX), 4)}
    read_e = p.read_lin / p.k_lin
    # The scene model's bound: a gain fitted near zero (frames whose codec
    # took the temporal noise away) would put these in the millions of electrons.
    if p.row_lin is not None and p.row_lin / p.k_lin > 0.05 * read_e:
        effects["row_noise"] = {"std_e": round(min(p.row_lin / p.k_lin, MAX_PATTERN_E), 4)}
    if p.col_lin is not None and p.col_lin / p.k_lin > 0.05 * read_e:
        effects["column_fpn"] = {"std_e": round(min(p.col_lin / p.k_lin, MAX_PATTERN_E), 4)}
    if profile is not None:
        effects["led_profile"] = {"profile": "table", "radial_table": profile}
    return effects


def fitted_scene(base: Scene, shape, clock_hz: float, m: Measured, p: Parameters, notes: list,
                 plane: str = "grey", recording=None, frame_rate_hz: float | None = None,
                 jpeg_quality: int | None = None) -> Scene:
    """The base scene with the fitted camera, ISP, LED image and ambient light.

    ``plane``: what of the frames was fitted, ``grey`` or a colour plane
    (``red``, ``green``, ``blue``). Colour frames are rendered through a
    Bayer filter and demosaicing (RGGB, the effect's defaults), whose blur
    and noise the fit then sees as the frames' were seen, and the fitted
    levels are those of the plane's channel (:func:`plane_response`).
    ``recording`` (:class:`rollsim.video.VideoSettings`): the frames came
    from a video so encoded, which the scene then renders through
    (``video_codec``), at the video's ``frame_rate_hz``. ``jpeg_quality``: the
    frames were saved as JPEG of that quality (:func:`rollsim.fit.compression.jpeg_quality`),
    which the scene then renders through (``jpeg``).
    """
    from rollsim.optics import led_image_size_px
    from rollsim.optics.scene_light import ambient_electron_rates
    from rollsim.render.tuning import on_level_electrons
    from rollsim.scene import scene_from_dict

    colour = plane != "grey"

    data = base.model_dump(mode="json", exclude_none=True)
    camera = data["camera"]
    camera.pop("ifg_ratio", None)
    row_time_s = m.row_time_s
    gamma = p.gamma if abs(p.gamma - 1.0) >= MIN_GAMMA_CHANGE else 1.0
    smoothing = p.smoothing_rows if p.smoothing_rows >= MIN_SMOOTHING_ROWS else 0.0
    iso = base.camera.iso * p.k_lin / gain_per_full_scale(base)  # the gain is proportional to the ISO
    # Stills do not show the frame rate: the base scene's, unless the rows
    # read out, or the exposure, take longer than its frame period (then
    # the longer of the two, the readout with a 1 % gap).
    if frame_rate_hz is not None:  # a video's rate, unlike stills'
        camera["frame_rate_hz"] = frame_rate_hz
    readout_s = shape[0] * row_time_s
    exposure_s = p.exposure_rows * row_time_s
    needed_s = max(readout_s * FRAME_GAP, exposure_s)
    if needed_s > 1.0 / camera["frame_rate_hz"]:
        camera["frame_rate_hz"] = 1.0 / needed_s
        notes.append(f"the frame rate is lowered to {camera['frame_rate_hz']:.4g} Hz so that the rows and the "
                     "exposure fit a frame")
    exposure_us = exposure_s * 1e6
    k, offset = m.binning
    if shape[0] % k:
        notes.append(f"rows come in groups of {k} (binned readout), but {k} does not divide the height: "
                     "rendered unbinned")
        k = 1
    elif offset:
        notes.append(f"rows come in groups of {k} starting at row {offset}; rendered with groups from row 0")
    camera.update(binning_rows=k, width_px=shape[1], height_px=shape[0], row_time_us=row_time_s * 1e6,
                  exposure_us=max(exposure_us, 1e-3), iso=min(max(iso, 1.0), 1e7),
                  read_noise_e=min(p.read_lin / p.k_lin, 1e4), output="rgb8" if colour else "gray8")
    # Frames that clip do so at 255, the ADC's full scale: the well holds at
    # least that many electrons (a low fitted gain would otherwise clip the
    # well first, below 255).
    full_scale_e = 1.0 / p.k_lin
    if camera["full_well_e"] < FULL_WELL_MARGIN * full_scale_e:
        camera["full_well_e"] = min(1e7, FULL_WELL_MARGIN * full_scale_e)
    data["link"].update(clock_hz=clock_hz, pattern="square")
    data["effects"] = _effects(data.get("effects", {}), p, gamma, smoothing, m.profile)
    if colour:
        data["effects"]["bayer"] = {"pattern": "RGGB"}
    if jpeg_quality is not None:
        data["effects"]["jpeg"] = {"quality": int(jpeg_quality)}
    if recording is not None:
        from rollsim.effects.video_codec import params_of

        data["effects"]["video_codec"] = params_of(recording)
    x, y, diameter = led_disk_px(m, shape)
    data["led"]["position_px"] = [x, y]
    data["led"]["shape"] = "disk"
    sized = scene_from_dict(data, "fitted scene")
    data["led"]["size_mm"] = min(MAX_LED_SIZE_MM, sized.led.size_mm * diameter / led_image_size_px(sized))

    # Ambient light from the background's linear level, or (no background)
    # from the OFF rows: the ambient light on the LED's face.
    sized = scene_from_dict(data, "fitted scene")
    exposure_s = sized.camera.exposure_s
    k_lin = gain_per_full_scale(sized)
    led_factor, ambient_factor = plane_response(sized, plane)
    bg_rate, face_rate = (rate * ambient_factor for rate in ambient_electron_rates(sized))
    if m.background is not None:
        wanted, rate = float(linear_level(m.background, gamma)) / k_lin, bg_rate
    else:
        wanted, rate = p.off_lin / k_lin, face_rate
    if rate > 0:
        lux = sized.environment.ambient_lux * wanted / (rate * exposure_s)
        if lux > MAX_AMBIENT_LUX:
            notes.append(f"the ambient light is capped at {MAX_AMBIENT_LUX:g} lx (the frames ask {lux:.3g} lx)")
        data["environment"]["ambient_lux"] = min(lux, MAX_AMBIENT_LUX)
    sized = scene_from_dict(data, "fitted scene")
    # The linear ON level over the LED's rows; the intensity is linear in it.
    on_e = p.on_lin / k_lin
    mono_face_e = ambient_electron_rates(sized)[1] * exposure_s
    led_e = (on_level_electrons(sized) - mono_face_e) * led_factor
    face_e = mono_face_e * ambient_factor
    if led_e > 0 and on_e > face_e:
        data["led"]["luminous_intensity_cd"] = min(MAX_INTENSITY_CD,
                                                   sized.led.luminous_intensity_cd * (on_e - face_e) / led_e)
        # OFF rows above the ambient light on the LED's face (an LED never
        # fully off, or glare from the ON rows around them): the LED's OFF level.
        off_e = p.off_lin / k_lin
        data["led"]["off_level"] = round(min(MAX_OFF_LEVEL, max(0.0, (off_e - face_e) / (on_e - face_e))), 6) \
            if m.background is not None else 0.0
    else:
        notes.append("the LED's ON level does not clear the ambient light on its face: intensity kept")
    return scene_from_dict(data, "fitted scene")

