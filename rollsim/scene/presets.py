"""Camera presets, each value with its source.

A preset fills every ``camera`` key; a scene or ``--set`` overrides any of
them one by one (precedence: preset < scene file < ``--set``).

Row timing is given either as ``row_time_us`` (a published line delay) or as
``ifg_ratio`` (the paper's inter-frame gap ratio), never both.

Sensor values that manufacturers do not publish (full well, read noise, dark
current, PRNU/DSNU, conversion gain, black level) are marked "assumed". They
are typical of 1.4 µm back-side-illuminated smartphone pixels with a 10-bit
raw output, and close to ISETCam's published IMX363 model (Google Pixel 4a,
1.4 µm: 6000 e- full well, 5 e- read noise, 0.7 % PRNU, 10-bit, black level
64; Lyu et al., "Validation of image systems simulation technology using a
Cornell Box", Electronic Imaging 2021). The conversion gain and the full
well agree: the full well fills the ADC range above the black level at base
ISO, so neither clips first.
"""

from __future__ import annotations

from dataclasses import dataclass, field

OTH_2013 = (
    "Oth, Furgale, Kneip, Siegwart, 'Rolling Shutter Camera Calibration', "
    "CVPR 2013, pp. 1360-1367 (measured line delay)"
)
ASSUMED_SENSOR = "assumed: typical 1.4 um smartphone pixel, see module docstring"

_SENSOR = {
    "qe": (0.6, "assumed: peak QE of a BSI smartphone pixel in the red, where the paper's LED emits"),
    # 4359 = (2^10 - 1 - 64) DN / 0.22 DN/e-: the full well fills the ADC at
    # base ISO to within 0.02 DN (tested for every preset).
    "full_well_e": (4359, "assumed: typical 1.4 um smartphone pixel (about 4500 e-), set so that it fills "
                          "the 10-bit ADC above the black level at base ISO with the gain below"),
    "read_noise_e": (2.0, ASSUMED_SENSOR),
    "dark_current_e_per_s": (5.0, ASSUMED_SENSOR),
    "prnu_percent": (0.7, "assumed: ISETCam IMX363 model value"),
    "dsnu_e": (0.5, ASSUMED_SENSOR),
    "adc_bits": (10, "assumed: 10-bit RAW10 output, as the IMX179's sensor driver provides"),
    "black_level_dn": (64, "assumed: the usual 10-bit black level (ISETCam IMX363 model)"),
    "base_iso": (100, "assumed: unity analogue gain at ISO 100"),
    "gain_dn_per_e": (0.22, "assumed: about (2^10 - 1 - 64) DN / 4500 e-, the full well fills the ADC at base ISO"),
    "lens_transmission": (0.9, "assumed: typical transmission of a multi-element phone lens"),
    "output": ("gray8", "default output format"),
}


@dataclass(frozen=True)
class CameraPreset:
    """A camera preset: every ``camera`` key with a value and its source."""

    name: str
    description: str
    values: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """``{key: value}`` of the preset."""
        return {key: value for key, (value, _source) in self.values.items()}

    def sources(self) -> dict:
        """``{key: source}`` of the preset."""
        return {key: source for key, (_value, source) in self.values.items()}


def _preset(name, description, **values) -> CameraPreset:
    merged = dict(_SENSOR)
    merged.update(values)
    return CameraPreset(name, description, merged)


PRESETS = {
    preset.name: preset
    for preset in (
        _preset(
            "nexus5",
            "LG Nexus 5 (Sony IMX179, 1/3.2\"), 1080p30: the paper's receiver",
            width_px=(1920, "1080p video (paper §3)"),
            height_px=(1080, "1080p video (paper §3)"),
            frame_rate_hz=(30.0, "paper §3: up to 30 frames per second"),
            ifg_ratio=(0.1, "paper Table 1: camera inter-frame gap ratio d_g = 0.1"),
            exposure_us=(100.0, "paper §3: exposure 100 us"),
            iso=(10000.0, "paper §3: ISO 10000"),
            pixel_pitch_um=(1.4, "paper §3: 1.4 um pixels"),
            focal_length_mm=(3.97, "Nexus 5 EXIF focal length (about 30 mm equivalent; DPReview review)"),
            f_number=(2.4, "Nexus 5 specification, f/2.4 (DPReview, AnandTech)"),
        ),
        _preset(
            "galaxy_s3",
            "Samsung Galaxy S3, 1080p30, 30.25 us line delay",
            width_px=(1920, "1080p video mode of the measurement"),
            height_px=(1080, "1080p video mode of the measurement"),
            frame_rate_hz=(30.0, "30 fps video mode of the measurement"),
            row_time_us=(30.25, OTH_2013),
            exposure_us=(100.0, "assumed: the paper's short OCC exposure"),
            iso=(3200.0, "assumed: a high ISO for short-exposure OCC"),
            pixel_pitch_um=(1.4, "Galaxy S3 8 MP sensor, 1.4 um pixels (manufacturer specification)"),
            focal_length_mm=(3.7, "Galaxy S3 EXIF focal length"),
            f_number=(2.6, "Galaxy S3 specification, f/2.6"),
        ),
        _preset(
            "iphone4s",
            "Apple iPhone 4S, 1080p30, 24.12 us line delay",
            width_px=(1920, "1080p video mode of the measurement"),
            height_px=(1080, "1080p video mode of the measurement"),
            frame_rate_hz=(30.0, "30 fps video mode of the measurement"),
            row_time_us=(24.12, OTH_2013),
            exposure_us=(100.0, "assumed: the paper's short OCC exposure"),
            iso=(3200.0, "assumed: a high ISO for short-exposure OCC"),
            pixel_pitch_um=(1.4, "iPhone 4S 8 MP sensor, 1.4 um pixels (manufacturer specification)"),
            focal_length_mm=(4.28, "iPhone 4S EXIF focal length"),
            f_number=(2.4, "iPhone 4S specification, f/2.4"),
        ),
        _preset(
            "iphone6s",
            "Apple iPhone 6S, 720p30, 20.85 us line delay",
            width_px=(1280, "720p video mode of the measurement"),
            height_px=(720, "720p video mode of the measurement"),
            frame_rate_hz=(30.0, "30 fps video mode of the measurement"),
            row_time_us=(
                20.85,
                "line delay measured with an LED panel, table 4 of doc/rolling-shutter-table.md "
                "in J. Huai's kalibr fork (no peer-reviewed source found)",
            ),
            exposure_us=(100.0, "assumed: the paper's short OCC exposure"),
            iso=(3200.0, "assumed: a high ISO for short-exposure OCC"),
            pixel_pitch_um=(1.22, "iPhone 6S 12 MP sensor, 1.22 um pixels (manufacturer specification)"),
            focal_length_mm=(4.15, "iPhone 6S EXIF focal length"),
            f_number=(2.2, "iPhone 6S specification, f/2.2"),
        ),
        _preset(
            "iphone3gs",
            "Apple iPhone 3GS, 480p30, 64.41 us line delay",
            width_px=(640, "VGA video mode of the measurement"),
            height_px=(480, "VGA video mode of the measurement"),
            frame_rate_hz=(30.0, "30 fps video mode of the measurement"),
            row_time_us=(64.41, OTH_2013),
            exposure_us=(100.0, "assumed: the paper's short OCC exposure"),
            iso=(1600.0, "assumed: a high ISO for short-exposure OCC"),
            pixel_pitch_um=(1.75, "iPhone 3GS 3 MP sensor, 1.75 um pixels (manufacturer specification)"),
            focal_length_mm=(3.85, "iPhone 3GS EXIF focal length"),
            f_number=(2.8, "iPhone 3GS specification, f/2.8"),
        ),
    )
}

DEFAULT_PRESET = "nexus5"
