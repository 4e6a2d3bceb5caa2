"""The sensor: rolling-shutter timing and the EMVA 1288 linear camera model."""

from rollsim.sensor.adc import dn_to_gray8, electrons_to_dn, gray8_lut
from rollsim.sensor.timing import RowTiming

__all__ = ["RowTiming", "dn_to_gray8", "electrons_to_dn", "gray8_lut"]
