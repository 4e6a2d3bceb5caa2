"""The transmitter: broadcast strategies, chip sources and the LED waveform."""

from rollsim.transmitter.chips import ConstantChips, DataChips, SquareChips
from rollsim.transmitter.message import message_from_seed
from rollsim.transmitter.schedule import STRATEGIES, Schedule
from rollsim.transmitter.transmitter import PATTERNS, Transmitter, build_transmitter, phy_from_scene, transmitter_from_scene
from rollsim.transmitter.waveform import Waveform

__all__ = [
    "ConstantChips",
    "DataChips",
    "PATTERNS",
    "STRATEGIES",
    "Schedule",
    "SquareChips",
    "Transmitter",
    "Waveform",
    "build_transmitter",
    "message_from_seed",
    "phy_from_scene",
    "transmitter_from_scene",
]
