"""Radiometry: from candela and lux to photons per second per pixel.

Sensor-plane illuminance of a Lambertian surface of luminance L seen through
a lens of f-number N, transmission T, at magnification m (the camera
equation, on axis):

    E = π · L · T / (4 · N² · (1 + m)²)        [lx]

An LED of luminous intensity I_v over emitting area A has L = I_v / A. A
Lambertian background of reflectance ρ under ambient illuminance E_amb has
L = ρ · E_amb / π; for a distant background m → 0.

Illuminance becomes a photon rate through the light's spectrum: a lux-second
on one square metre is one lumen-second, and one lumen of a spectrum S(λ)
carries  ∫ S λ/(h c) dλ / (K_m ∫ S V dλ)  photons, with V the CIE 1924
photopic luminous efficiency function and K_m = 683 lm/W. V comes from
:mod:`rollsim.optics.photopic` (colour-science's table, read without
colour-science's two-second import). A CIE illuminant's photons per lumen
were computed once through colour-science by :func:`photons_per_lumen_spectrum`
and are listed in :data:`PHOTONS_PER_LUMEN_ILLUMINANTS` (tests/test_optics.py
recomputes them), so ambient light costs no colour-science import either.
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.optics.photopic import photopic_efficiency
from rollsim.plumbing.validation import as_positive, as_probability, check_nonnegative

PLANCK_J_S = 6.62607015e-34
LIGHT_SPEED_M_S = 299792458.0
K_M_LM_PER_W = 683.0
# Photons per lumen of the CIE standard illuminants: photons_per_lumen_spectrum
# of colour-science's SDS_ILLUMINANTS (0.4.7), as repr writes them.
PHOTONS_PER_LUMEN_ILLUMINANTS = {
    "FL2": 8118581125179521.0,
    "D65": 1.4546011548667716e16,
    "A": 2.1086614221521464e16,
    "FL11": 8230551916603990.0,
}
AMBIENT_ILLUMINANTS = tuple(PHOTONS_PER_LUMEN_ILLUMINANTS)


def luminous_efficiency(wavelength_nm: float) -> float:
    """CIE 1924 photopic V(λ) at ``wavelength_nm`` (:func:`rollsim.optics.photopic.photopic_efficiency`)."""
    return photopic_efficiency(wavelength_nm)


def photons_per_lumen_monochromatic(wavelength_nm: float) -> float:
    """Photons per lumen of monochromatic light: λ / (h c K_m V(λ)).

    Raises
    ------
    ValueError
        Where V(λ) is zero (outside the visible range), since no number of
        photons makes a lumen there.
    """
    v = luminous_efficiency(wavelength_nm)
    if not v > 0:
        raise ValueError(f"wavelength {wavelength_nm} nm has zero luminous efficiency; photons per lumen is undefined")
    return wavelength_nm * 1e-9 / (PLANCK_J_S * LIGHT_SPEED_M_S * K_M_LM_PER_W * v)


def photons_per_lumen_spectrum(sd) -> float:
    """Photons per lumen of a colour ``SpectralDistribution`` (any scale).

    Imports colour-science (about two seconds).
    """
    import colour

    wavelengths_m = np.asarray(sd.wavelengths, dtype=np.float64) * 1e-9
    power = np.asarray(sd.values, dtype=np.float64)
    photons = np.trapezoid(power * wavelengths_m / (PLANCK_J_S * LIGHT_SPEED_M_S), sd.wavelengths)
    lumens = colour.luminous_flux(sd, K_m=K_M_LM_PER_W)
    return float(photons / lumens)


def photons_per_lumen_illuminant(name: str) -> float:
    """Photons per lumen of a CIE standard illuminant (``FL2``, ``D65``, ...)."""
    if name not in PHOTONS_PER_LUMEN_ILLUMINANTS:
        raise ValueError(f"unknown illuminant {name!r}; expected one of {list(AMBIENT_ILLUMINANTS)}")
    return PHOTONS_PER_LUMEN_ILLUMINANTS[name]


def led_luminance_cd_m2(luminous_intensity_cd: float, emitting_area_m2: float) -> float:
    """Luminance L = I_v / A (cd/m²) of an LED with a uniform emitting face.

    ``luminous_intensity_cd`` >= 0; ``emitting_area_m2`` > 0.
    """
    check_nonnegative(luminous_intensity_cd, "luminous_intensity_cd")
    as_positive(emitting_area_m2, "emitting_area_m2")
    return luminous_intensity_cd / emitting_area_m2


def lambertian_luminance_cd_m2(illuminance_lx: float, reflectance: float) -> float:
    """Luminance L = ρ E / π (cd/m²) of a Lambertian surface.

    ``illuminance_lx`` >= 0 (a number or an array); ``reflectance`` in [0, 1].
    """
    check_nonnegative(illuminance_lx, "illuminance_lx")
    reflectance = as_probability(reflectance, "reflectance")
    return reflectance * illuminance_lx / math.pi


def sensor_illuminance_lx(luminance_cd_m2: float, f_number: float, transmission: float, magnification: float = 0.0) -> float:
    """Camera equation: E = π L T / (4 N² (1 + m)²), in lux, on axis.

    ``luminance_cd_m2`` >= 0 (a number or an array); ``f_number`` > 0;
    ``transmission`` in [0, 1]; ``magnification`` >= 0.
    """
    check_nonnegative(luminance_cd_m2, "luminance_cd_m2")
    f_number = as_positive(f_number, "f_number")
    transmission = as_probability(transmission, "transmission")
    magnification = as_positive(magnification, "magnification", allow_zero=True)
    return math.pi * luminance_cd_m2 * transmission / (4.0 * f_number**2 * (1.0 + magnification) ** 2)


def photon_rate_per_pixel(illuminance_lx: float | np.ndarray, pixel_pitch_m: float,
                          photons_per_lumen: float | np.ndarray) -> float | np.ndarray:
    """Photons per second reaching one pixel of pitch ``pixel_pitch_m`` (m, > 0).

    ``illuminance_lx`` and ``photons_per_lumen`` >= 0, numbers or arrays.
    """
    check_nonnegative(illuminance_lx, "illuminance_lx")
    pixel_pitch_m = as_positive(pixel_pitch_m, "pixel_pitch_m")
    check_nonnegative(photons_per_lumen, "photons_per_lumen")
    return illuminance_lx * pixel_pitch_m**2 * photons_per_lumen
