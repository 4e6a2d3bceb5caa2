"""What a still's EXIF says of the camera's settings: the exposure time, ISO and camera.

A phone's or a camera's JPEG still records its exposure time
(``ExposureTime``, seconds) and sensitivity (``ISOSpeedRatings``) in its
EXIF block. The exposure is what a square wave's stripes tell only up to
whole stripe periods and a reflection (:mod:`rollsim.fit.refine`), so
``fit-camera`` holds the EXIF exposure as given, as it holds
``--exposure-us``. Stills whose exposures differ were not taken with the
settings locked, and one fit cannot serve them all.

The tags are read with Pillow (which reads the header only, not the image).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from decoder.io import JPEG_SIGNATURE

# EXIF tags: IFD0's pointer to the Exif IFD, and the tags read from each.
EXIF_IFD = 0x8769
EXPOSURE_TIME = 0x829A
ISO_SPEED = 0x8827
MAKE, MODEL = 0x010F, 0x0110
# Exposure times that differ by less than this fraction are one setting (a
# rational written with another denominator).
SAME_EXPOSURE = 1e-3


@dataclass(frozen=True)
class StillSettings:
    """The settings one still's EXIF records (None where it does not)."""

    path: str
    exposure_us: float | None
    iso: float | None
    camera: str | None


def _number(value) -> float | None:
    """A finite, positive EXIF number (a rational, an int or a one-element tuple), else None."""
    if isinstance(value, (tuple, list)):
        value = value[0] if len(value) == 1 else None
    try:
        number = float(value)
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return number if math.isfinite(number) and number > 0 else None


def still_settings(path: Path) -> StillSettings:
    """The exposure (µs), ISO and camera (make and model) that the EXIF of the still at ``path`` records.

    A file that is not a JPEG (a PNG: rollsim's own metadata is in text
    chunks, and Pillow would decode a PNG's image to look for EXIF), a JPEG
    saved without EXIF, or one whose tags cannot be read gives None for each.
    """
    from PIL import Image, UnidentifiedImageError

    nothing = StillSettings(str(path), None, None, None)
    try:
        with open(path, "rb") as handle:
            if handle.read(len(JPEG_SIGNATURE)) != JPEG_SIGNATURE:
                return nothing
        with Image.open(path) as image:
            exif = image.getexif()
            tags = exif.get_ifd(EXIF_IFD)
    except (OSError, UnidentifiedImageError, ValueError, SyntaxError):  # Pillow's errors for a damaged header
        return nothing
    seconds = _number(tags.get(EXPOSURE_TIME))
    camera = " ".join(str(exif[t]).strip("\x00 ") for t in (MAKE, MODEL) if isinstance(exif.get(t), str)).strip()
    return StillSettings(str(path), None if seconds is None else seconds * 1e6, _number(tags.get(ISO_SPEED)),
                         camera or None)


def _seconds_text(exposure_us: float) -> str:
    """An exposure as a camera shows it: 1/2000 s, or 0.5 s."""
    seconds = exposure_us * 1e-6
    return f"1/{1.0 / seconds:.0f} s" if seconds < 0.5 else f"{seconds:g} s"


def locked_exposure_us(settings: Sequence[StillSettings]) -> float | None:
    """The one exposure (µs) that every still's EXIF records, or None where none records one.

    Raises
    ------
    ValueError
        Some stills record an exposure and others none, or two record
        different exposures: the camera's settings were not locked. The
        message names the files.
    """
    told = [(s.exposure_us, s.path) for s in settings if s.exposure_us is not None]
    if not told:
        return None
    if len(told) < len(settings):
        missing = next(s.path for s in settings if s.exposure_us is None)
        raise ValueError(f"{missing}: no EXIF exposure time, where {told[0][1]} records "
                         f"{_seconds_text(told[0][0])}: give frames of one camera and setting "
                         "(or --exposure-us)")
    (low, low_path), (high, high_path) = min(told), max(told)
    if high > low * (1.0 + SAME_EXPOSURE):
        raise ValueError(f"the stills were taken at different exposures ({low_path}: {_seconds_text(low)}, "
                         f"{high_path}: {_seconds_text(high)}, EXIF ExposureTime): fit-camera needs frames "
                         "taken with the camera's exposure locked")
    return float(sorted(us for us, _ in told)[len(told) // 2])


def exposure_how(exposure_us: float, settings: Sequence[StillSettings]) -> str:
    """How the exposure was found, for ``fit.json``: the stills' EXIF, with its value and camera."""
    cameras = sorted({s.camera for s in settings if s.camera})
    isos = sorted({s.iso for s in settings if s.iso is not None})
    said = [_seconds_text(exposure_us)]
    if len(cameras) == 1:
        said.append(cameras[0])
    if len(isos) == 1:
        said.append(f"ISO {isos[0]:g}")
    return f"held as the stills' EXIF ExposureTime gives it ({'; '.join(said)})"
