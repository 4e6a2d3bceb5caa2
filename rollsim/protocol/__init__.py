"""The PHY-SDU format shared by the transmitter and the decoder.

The :mod:`decoder` package imports only this subpackage from rollsim, so
nothing here may depend on the rest of rollsim.
"""

from rollsim.protocol.checks import CHECK_BITS, CRC8_MAX_DATA_BITS, check_bits, crc8, parity2, verify
from rollsim.protocol.linecode import LINE_CODES, FOUR_B_SIX_B_TABLE, max_run_length
from rollsim.protocol.packets import (
    bits_to_int,
    depacketize,
    int_to_bits,
    last_payload_bits,
    min_header_bits,
    n_packets,
    packetize,
)
from rollsim.protocol.phy import DecodedSdus, PhyFormat, camcomsim_sdu_duration_s, sync_pattern

__all__ = [
    "CHECK_BITS",
    "CRC8_MAX_DATA_BITS",
    "DecodedSdus",
    "FOUR_B_SIX_B_TABLE",
    "LINE_CODES",
    "PhyFormat",
    "bits_to_int",
    "camcomsim_sdu_duration_s",
    "check_bits",
    "crc8",
    "depacketize",
    "int_to_bits",
    "last_payload_bits",
    "max_run_length",
    "min_header_bits",
    "n_packets",
    "packetize",
    "parity2",
    "sync_pattern",
    "verify",
]
