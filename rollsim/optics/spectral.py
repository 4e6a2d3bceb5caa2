"""Colour from spectra: electrons per lumen in each colour channel.

Illuminance becomes electrons through a spectrum. A light of spectral power
S(λ) (any scale) whose illuminance on the sensor is E_v (lx) puts on a pixel
of area a, per second and per colour channel c,

    rate_c = E_v · a · ∫ S(λ) · λ/(h·c) · QE_c(λ) dλ  /  (K_m · ∫ S(λ) · V(λ) dλ)

electrons (:func:`electrons_per_lumen` is the fraction): the denominator
turns the photometric E_v into spectral power, the numerator counts the
photons each channel converts. V is the CIE 1924 photopic luminous efficiency
and K_m = 683 lm/W.

Spectra, all from colour-science:

* LED: the Ohno (2005) single-LED model at ``led.peak_wavelength_nm``,
  (g + 2g⁵)/3 with g = exp(−((λ − λ_p)/Δλ)²), as ``colour.sd_single_led``
  defines it, computed here with the portable exponential
  (:mod:`rollsim.numerics.portable_math`) so that its bits do not depend on the
  CPU. Its width Δλ is not the full width at half maximum: the model's
  FWHM is 0.9218·Δλ, so a requested FWHM is divided by
  :data:`OHNO_FWHM_PER_WIDTH` first.
* Ambient light: CIE standard illuminants (``FL2``, ``FL11``, ``D65``, ``A``).
* Camera: the NPL-measured camera sensitivities that colour-science ships
  (``colour.MSDS_CAMERA_SENSITIVITIES``). Each channel of those datasets is
  normalised to a peak of 1, so the relative channel gains are not in the
  data; the curves are scaled so that the highest value over wavelength and
  channels equals ``camera.qe``, which gives every channel a peak QE of
  ``camera.qe``. Outside a dataset's range (e.g. beyond 680 nm for the Sigma)
  the QE is taken as 0, as behind an IR-cut filter. The Sigma SD Merrill has
  a layered (Foveon X3) sensor whose three curves overlap strongly; used as
  colour-filter curves they give little colour separation.

Integration: the trapezoid rule on a 360–830 nm grid at 1, 5 or 10 nm, with
the tabulated data interpolated linearly (the LED model is evaluated on the
grid directly). ``peak`` instead treats the LED as a line at its peak
wavelength, QE_c(λ_p)·λ_p/(h·c·K_m·V(λ_p)), as the monochrome render does;
the illuminants, which have no single peak, are then integrated at 10 nm.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from rollsim.optics.radiometry import K_M_LM_PER_W, LIGHT_SPEED_M_S, PLANCK_J_S, photons_per_lumen_monochromatic
from rollsim.numerics.portable_math import exp, log

CAMERA_SENSITIVITIES = {
    "nikon_5100": "Nikon 5100 (NPL)",
    "sigma_sdmerill": "Sigma SDMerill (NPL)",
}
SPECTRAL_STEPS = (1, 5, 10, "peak")
GRID_NM = (360, 830)
# Step at which the illuminants are integrated when the LED is taken as a line.
PEAK_ILLUMINANT_STEP_NM = 10


def _colour():
    # colour-science takes about two seconds to import: only a spectral
    # render (the bayer effect) pays for it.
    import colour

    return colour


def _ohno_fwhm_per_width() -> float:
    # Half maximum of (g + 2 g^5)/3 with g = exp(-x²): 2 g^5 + g − 3/2 = 0,
    # whose one root in (0, 1) bisection finds to the last bit (the left side
    # rises with g), the same on every machine.
    lo, hi = 0.0, 1.0
    while True:
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        if 2.0 * (mid * mid) * (mid * mid) * mid + mid - 1.5 < 0.0:
            lo = mid
        else:
            hi = mid
    return 2.0 * float(np.sqrt(-log(hi)))


OHNO_FWHM_PER_WIDTH = _ohno_fwhm_per_width()


def wavelength_grid_nm(step_nm: int) -> np.ndarray:
    """The integration grid 360, 360 + step, …, 830 nm."""
    if step_nm not in (1, 5, 10):
        raise ValueError(f"step_nm must be 1, 5 or 10, got {step_nm!r}")
    return np.arange(GRID_NM[0], GRID_NM[1] + step_nm, step_nm, dtype=np.float64)


def _on_grid(wavelengths_nm, values, grid_nm: np.ndarray) -> np.ndarray:
    """Tabulated values interpolated linearly on the grid, 0 outside their range."""
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 1:
        return np.interp(grid_nm, wavelengths_nm, values, left=0.0, right=0.0)
    return np.stack([np.interp(grid_nm, wavelengths_nm, v, left=0.0, right=0.0) for v in values.T], axis=1)


def led_spectrum(peak_wavelength_nm: float, fwhm_nm: float, grid_nm: np.ndarray) -> np.ndarray:
    """Relative spectral power of a single LED (Ohno 2005) of the given FWHM (nm) on the grid (nm)."""
    g = exp(-(((np.asarray(grid_nm, dtype=np.float64) - peak_wavelength_nm) / (fwhm_nm / OHNO_FWHM_PER_WIDTH)) ** 2))
    g5 = g * g
    g5 *= g5
    g5 *= g
    return (g + 2.0 * g5) / 3.0


def illuminant_spectrum(name: str, grid_nm: np.ndarray) -> np.ndarray:
    """Relative spectral power of a CIE standard illuminant on the grid."""
    sd = _colour().SDS_ILLUMINANTS[name]
    return _on_grid(sd.wavelengths, sd.values, grid_nm)


def luminous_efficiency_on(grid_nm: np.ndarray) -> np.ndarray:
    """CIE 1924 photopic V(λ) on the grid."""
    v = _colour().colorimetry.SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    return _on_grid(v.wavelengths, v.values, grid_nm)


@lru_cache(maxsize=None)
def _sensitivity_table(name: str) -> tuple[np.ndarray, np.ndarray]:
    if name not in CAMERA_SENSITIVITIES:
        raise ValueError(f"unknown camera sensitivities {name!r}; expected one of {list(CAMERA_SENSITIVITIES)}")
    msds = _colour().MSDS_CAMERA_SENSITIVITIES[CAMERA_SENSITIVITIES[name]]
    return np.asarray(msds.wavelengths, dtype=np.float64), np.asarray(msds.values, dtype=np.float64)


def camera_qe(name: str, peak_qe: float, wavelengths_nm) -> np.ndarray:
    """QE of the R, G and B channels at ``wavelengths_nm``.

    Parameters
    ----------
    name : str
        A key of :data:`CAMERA_SENSITIVITIES`.
    peak_qe : float
        The highest QE over wavelength and channels (``camera.qe``).
    wavelengths_nm : array_like

    Returns
    -------
    ndarray, shape (n, 3)
        Electrons per photon; 0 outside the dataset's range.
    """
    wavelengths, values = _sensitivity_table(name)
    return peak_qe / values.max() * _on_grid(wavelengths, values, np.atleast_1d(np.asarray(wavelengths_nm, dtype=np.float64)))


def electrons_per_lumen(power: np.ndarray, qe_rgb: np.ndarray, grid_nm: np.ndarray) -> np.ndarray:
    """Electrons per lumen in each channel of light of spectral power ``power``.

    Parameters
    ----------
    power : ndarray, shape (n,)
        Relative spectral power on ``grid_nm`` (any scale).
    qe_rgb : ndarray, shape (n, 3)
    grid_nm : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (3,)
    """
    photons = power * grid_nm * 1e-9 / (PLANCK_J_S * LIGHT_SPEED_M_S)
    lumens = K_M_LM_PER_W * np.trapezoid(power * luminous_efficiency_on(grid_nm), grid_nm)
    if not lumens > 0:
        raise ValueError("the spectrum has no luminous flux: electrons per lumen are undefined")
    return np.trapezoid(photons[:, None] * qe_rgb, grid_nm, axis=0) / lumens


def led_electrons_per_lumen(peak_wavelength_nm: float, fwhm_nm: float, sensitivities: str, peak_qe: float, step_nm) -> np.ndarray:
    """Electrons per lumen of the LED in R, G and B (see the module docstring)."""
    if step_nm == "peak":
        qe = camera_qe(sensitivities, peak_qe, [peak_wavelength_nm])[0]
        return qe * photons_per_lumen_monochromatic(peak_wavelength_nm)
    grid = wavelength_grid_nm(step_nm)
    return electrons_per_lumen(led_spectrum(peak_wavelength_nm, fwhm_nm, grid), camera_qe(sensitivities, peak_qe, grid), grid)


def illuminant_electrons_per_lumen(name: str, sensitivities: str, peak_qe: float, step_nm) -> np.ndarray:
    """Electrons per lumen of a CIE illuminant in R, G and B."""
    grid = wavelength_grid_nm(PEAK_ILLUMINANT_STEP_NM if step_nm == "peak" else step_nm)
    return electrons_per_lumen(illuminant_spectrum(name, grid), camera_qe(sensitivities, peak_qe, grid), grid)
