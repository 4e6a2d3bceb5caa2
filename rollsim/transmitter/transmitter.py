"""The transmitter of a scene: message, PHY-SDUs, schedule and waveform.

It also maps times back to what was being sent (chip, tx index, sequence
number, bit), which is the basis of the render's ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rollsim.plumbing.budget import check_memory
from rollsim.protocol import PhyFormat, n_packets, packetize
from rollsim.transmitter.chips import ChipSource, ConstantChips, DataChips, SquareChips, prefix_dtype
from rollsim.transmitter.message import message_from_seed
from rollsim.transmitter.schedule import RlncSchedule, Schedule, schedule_for
from rollsim.transmitter.waveform import Waveform

if TYPE_CHECKING:
    from rollsim.scene_sections import SceneSections

PATTERNS = ("data", "square", "on", "off")


@dataclass(frozen=True)
class Transmitter:
    """Everything the LED sends.

    Attributes
    ----------
    phy : PhyFormat
        PHY-SDU layout.
    message : bytes
    payloads : ndarray of uint8, shape (n_packets, payload_bits)
        The message's source packets.
    sdu_chips : ndarray of uint8, shape (n_sequences, phy.sdu_chips)
        Chips of the PHY-SDU with sequence number k in row k (for ``rlnc``,
        of the coded PHY-SDU whose header carries seed k, one per seed).
    schedule : Schedule or RlncSchedule
    pattern : {"data", "square", "on", "off"}
    waveform : Waveform
        s(t) and S(t).
    """

    phy: PhyFormat
    message: bytes
    payloads: np.ndarray
    sdu_chips: np.ndarray
    schedule: Schedule | RlncSchedule
    pattern: str
    waveform: Waveform

    @property
    def n_packets(self) -> int:
        return self.schedule.n_packets

    @property
    def sdu_duration_s(self) -> float:
        return self.phy.sdu_duration_s(self.waveform.clock_hz)

    @property
    def sends_data(self) -> bool:
        """Whether the LED sends PHY-SDUs (pattern ``data``)."""
        return self.pattern == "data"

    def emission_start_s(self, tx) -> np.ndarray:
        """Start time in seconds of each emission (tx index)."""
        return self.waveform.start_s + np.asarray(tx, dtype=np.int64) * self.sdu_duration_s

    def emissions_between(self, t_start_s: float, t_end_s: float) -> np.ndarray:
        """tx indices of every PHY-SDU that overlaps [t_start, t_end)."""
        if not self.sends_data:
            return np.zeros(0, dtype=np.int64)
        first = int(np.floor((t_start_s - self.waveform.start_s) / self.sdu_duration_s))
        last = int(np.ceil((t_end_s - self.waveform.start_s) / self.sdu_duration_s)) - 1
        return np.arange(first, max(first, last) + 1, dtype=np.int64)

    def codeword_bits(self, tx) -> np.ndarray:
        """Header, payload and check bits of each emission, one row per tx."""
        seq = self.schedule.sequence_numbers(tx)
        return self.phy.codewords(seq, sent_payloads(self.payloads, self.schedule, seq))

    def locate(self, t_s) -> dict[str, np.ndarray]:
        """What was being sent at times ``t_s``.

        Returns
        -------
        dict of ndarray
            ``chip`` (chip index), ``level`` (1 ON / 0 OFF) and, for the
            ``data`` pattern, ``tx`` (tx index), ``sequence``, ``chip_in_sdu``
            and ``bit`` (codeword bit index, -1 in the SYNC; see
            :meth:`PhyFormat.bit_index_of_chip`). For other patterns these
            three are -1.
        """
        chip = self.waveform.chip_index(t_s)
        out = {"chip": chip, "level": self.waveform.chips.values(chip)}
        chips = self.waveform.chips
        if isinstance(chips, DataChips):  # the data pattern's
            tx, offset = chips.split(chip)
            out.update(
                tx=tx,
                sequence=self.schedule.sequence_numbers(tx),
                chip_in_sdu=offset,
                bit=self.phy.bit_index_of_chip(offset),
            )
        else:
            minus_one = np.full(np.shape(chip), -1, dtype=np.int64)
            out.update(tx=minus_one, sequence=minus_one, chip_in_sdu=minus_one, bit=minus_one)
        return out


# Packets encoded at a time: the line code's temporaries (int64 bit
# arrays) stay a few tens of MB whatever the message size.
_ENCODE_BLOCK = 1 << 16


def transmitter_bytes(phy: PhyFormat, message_bytes: int, packets: int | None = None) -> int:
    """Peak bytes :func:`build_transmitter` allocates for a message.

    The message and its bits (9 bytes per byte), then per packet its payload
    bits, its chips (1 byte each), their running ON counts
    (:func:`~rollsim.transmitter.chips.prefix_dtype`) and an int64 total;
    plus one encoding block's temporaries. ``packets`` overrides the count
    (the coded PHY-SDUs of ``rlnc``, one per seed).
    """
    packets = n_packets(message_bytes, phy.payload_bits) if packets is None else packets
    prefix = prefix_dtype(phy.sdu_chips).itemsize
    per_packet = phy.payload_bits + phy.sdu_chips + (phy.sdu_chips + 1) * prefix + 8
    block = min(packets, _ENCODE_BLOCK) * (phy.codeword_bits * 8 * 2 + phy.sdu_chips * 2)
    return 9 * message_bytes + packets * per_packet + block


# Seeds combined at a time: the combination matrix (seeds x packets, as
# int64 in the GF(2) product) stays a few tens of MB for a message of
# thousands of packets.
_CODED_BLOCK = 1 << 12


def sent_payloads(payloads: np.ndarray, schedule: Schedule | RlncSchedule, sequence) -> np.ndarray:
    """The payload bits sent under each sequence number: the packet's, or for rlnc the seed's combination."""
    sequence = np.asarray(sequence, dtype=np.int64)
    if isinstance(schedule, RlncSchedule):
        from rollsim.protocol.rlnc import encode

        return encode(payloads, sequence).astype(np.uint8)
    return payloads[sequence]


def _encode_blocks(phy: PhyFormat, payloads: np.ndarray, schedule: Schedule | RlncSchedule) -> np.ndarray:
    """Chips of the PHY-SDU of every sequence number (row k: sequence number k), block by block."""
    n = schedule.n_sequences
    block = _CODED_BLOCK if isinstance(schedule, RlncSchedule) else _ENCODE_BLOCK
    table = np.empty((n, phy.sdu_chips), dtype=np.uint8)
    for first in range(0, n, block):
        sequence = np.arange(first, min(first + block, n))
        table[first : sequence[-1] + 1] = phy.encode(sequence, sent_payloads(payloads, schedule, sequence))
    return table


def build_transmitter(
    phy: PhyFormat,
    message: bytes,
    strategy: str = "rp",
    repeats: int = 1,
    pattern: str = "data",
    clock_hz: float = 8000.0,
    start_s: float = 0.0,
    off_level: float = 0.0,
) -> Transmitter:
    """Assemble a transmitter from its parts.

    Parameters
    ----------
    phy : PhyFormat
    message : bytes
    strategy : {"rp", "rs", "rlnc"}
    repeats : int
        r of the strategy (1 for ``rlnc``).
    pattern : {"data", "square", "on", "off"}
        ``data`` sends the strategy's PHY-SDUs; ``square`` a chip-rate square
        wave (row-time calibration); ``on`` / ``off`` a constant level (flat
        fields).
    clock_hz : float
        Chip rate in Hz.
    start_s : float
        Time at which chip 0 (the first chip of tx 0) starts.
    off_level : float
        OFF intensity as a fraction of ON.
    """
    if pattern not in PATTERNS:
        raise ValueError(f"unknown pattern {pattern!r}; expected one of {list(PATTERNS)}")
    packets = n_packets(len(message), phy.payload_bits)
    if packets > (1 << phy.header_bits):
        raise ValueError(f"{packets} packets need more than {phy.header_bits} header bits")
    check_memory(f"link.message_bytes = {len(message)} ({packets} packets of {phy.sdu_chips} chips)",
                 transmitter_bytes(phy, len(message)))
    payloads = packetize(message, phy.payload_bits)
    schedule = schedule_for(strategy, packets, repeats, phy.header_bits)
    if isinstance(schedule, RlncSchedule):
        # One coded PHY-SDU per seed the header cycles through.
        check_memory(f"link.header_bits = {phy.header_bits} (strategy rlnc: {schedule.seed_space} coded PHY-SDUs "
                     f"of {phy.sdu_chips} chips)", transmitter_bytes(phy, 0, schedule.seed_space))
    sdu_chips = _encode_blocks(phy, payloads, schedule)
    chips: ChipSource
    if pattern == "data":
        chips = DataChips(schedule, sdu_chips)
    elif pattern == "square":
        chips = SquareChips()
    else:
        chips = ConstantChips(1 if pattern == "on" else 0)
    waveform = Waveform(chips, clock_hz, start_s, 1.0, off_level)
    return Transmitter(phy, message, payloads, sdu_chips, schedule, pattern, waveform)


def phy_from_scene(scene: SceneSections) -> PhyFormat:
    """The PHY-SDU layout of a scene's link."""
    link = scene.link
    return PhyFormat(link.header_bits, link.payload_bits, link.check, link.line_code)


def transmitter_from_scene(scene: SceneSections) -> Transmitter:
    """The transmitter a validated :class:`rollsim.scene.Scene` describes."""
    link = scene.link
    return build_transmitter(
        phy_from_scene(scene),
        message_from_seed(scene.seed, link.message_bytes),
        strategy=link.strategy,
        repeats=link.repeats,
        pattern=link.pattern,
        clock_hz=link.clock_hz,
        start_s=link.start_offset_us * 1e-6,
        off_level=scene.led.off_level,
    )
