"""Conversion gain, ADC and output formats (the end of the EMVA 1288 chain)."""

from __future__ import annotations

import numpy as np

from rollsim.sensor.tone import ToneCurve
from rollsim.plumbing.validation import as_count, as_positive


def electrons_to_dn(electrons: np.ndarray, gain_dn_per_e: float, black_level_dn: int, adc_bits: int) -> np.ndarray:
    """ADC: DN = clip(round(K·e) + black level, 0, 2^bits − 1), as uint16.

    Rounds half up: floor(K·e + black + 0.5). Works in the dtype of
    ``electrons`` (float32 after shot noise, float64 for noiseless means).

    Parameters
    ----------
    electrons : ndarray
        Electrons per pixel (after noise and the full-well clip).
    gain_dn_per_e : float
        Conversion gain K at the set ISO, DN per electron.
    black_level_dn : int
    adc_bits : int
    """
    as_positive(gain_dn_per_e, "gain_dn_per_e")
    as_count(black_level_dn, "black_level_dn")
    if not 1 <= as_count(adc_bits, "adc_bits") <= 16:
        raise ValueError(f"adc_bits must be in [1, 16] (uint16 output), got {adc_bits!r}")
    if electrons.dtype.kind != "f":
        electrons = electrons.astype(np.float64)  # counts: the arithmetic needs a float type
    dtype = electrons.dtype.type
    dn = electrons * dtype(gain_dn_per_e)
    dn += dtype(black_level_dn + 0.5)
    # Clip before the cast (which truncates): to [0, 2^bits - 1 + 0.5).
    np.clip(dn, 0.0, dtype(2**adc_bits - 0.5), out=dn)
    return dn.astype(np.uint16)


def full_scale_electrons(adc_bits: int, black_level_dn: int, gain_dn_per_e: float) -> float:
    """Electrons that fill the ADC range above the black level: (2^bits − 1 − black) / K.

    Parameters
    ----------
    adc_bits : int
    black_level_dn : int
    gain_dn_per_e : float
        Conversion gain K at the set ISO, DN per electron.
    """
    as_positive(gain_dn_per_e, "gain_dn_per_e")
    return (2 ** as_count(adc_bits, "adc_bits") - 1 - as_count(black_level_dn, "black_level_dn")) / gain_dn_per_e


def gray8_lut(black_level_dn: int, adc_bits: int, tone: ToneCurve | None = None) -> np.ndarray:
    """The gray8 value of every DN, 0 … 2^bits − 1 (see :func:`dn_to_gray8`)."""
    return dn_to_gray8(np.arange(2**adc_bits, dtype=np.uint16), black_level_dn, adc_bits, tone)


def dn_to_gray8(dn: np.ndarray, black_level_dn: int, adc_bits: int, tone: ToneCurve | None = None) -> np.ndarray:
    """8-bit grey image: black level removed and clipped at 0, range scaled to 0…255.

    v = (DN − black) / (2^bits − 1 − black), clipped to [0, 1] (the ISP's
    black clip: a dark pixel's negative noise is lost), optionally mapped by
    a tone curve (the ``tone_curve`` effect), then rounded to 0…255.

    Parameters
    ----------
    dn : ndarray of int
    black_level_dn : int
    adc_bits : int
    tone : ToneCurve, optional
        None for linear output.
    """
    full_scale = float(2**adc_bits - 1 - black_level_dn)
    if full_scale <= 0:
        raise ValueError("black level leaves no ADC range")
    v = (dn.astype(np.float32) - np.float32(black_level_dn)) * np.float32(1.0 / full_scale)
    np.clip(v, 0.0, 1.0, out=v)
    if tone is not None:
        v = tone(v)
    v *= np.float32(255.0)
    return np.rint(v).astype(np.uint8)
