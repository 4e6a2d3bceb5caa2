"""The receiver after the decoder: the message, recovered from the PHY-SDUs decoded.

Whatever the strategy, a receiver holds the PHY-SDUs that passed their
check, in the order it read them (frame by frame, row by row), and the
message is received when they determine it:

* RP and RS: when every sequence number 0 … K−1 has been read; the
  message is the payloads in sequence order;
* rlnc: when the combinations the seeds name reach rank K over GF(2); the
  message is the solution of the system (:func:`rollsim.protocol.gf2.eliminate`).

So goodput is computed the same way for every strategy: the message's bits
over the time from the first frame's start to the moment the camera has
read the PHY-SDU that made the message decodable (the end of the exposure
of its last row). A PHY-SDU that passed its check
with wrong bits (an undetected error) is used like any other, and the
message recovered is then compared bit for bit with the one sent.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from rollsim.protocol import depacketize
from rollsim.protocol.gf2 import eliminate, first_full_rank
from rollsim.protocol.rlnc import combinations


@dataclass(frozen=True)
class MessageReception:
    """When and how the message was received.

    Attributes
    ----------
    decodable : bool
        The PHY-SDUs read determine the message.
    message_ok : bool or None
        The message recovered equals the one sent, bit for bit (None when
        not decodable).
    receptions : int
        PHY-SDUs read with their check passed, up to and including the one
        that made the message decodable (all of them if it never was).
    frame : int or None
        Frame in which the message became decodable.
    duration_s : float or None
        From the first frame's start to the end of the exposure of the last
        row of the PHY-SDU that made the message decodable, s.
    goodput_bps : float
        Message bits / ``duration_s``; 0 when not decodable.
    """

    decodable: bool
    message_ok: bool | None
    receptions: int
    frame: int | None
    duration_s: float | None
    goodput_bps: float

    def as_dict(self) -> dict:
        return asdict(self)


def _read_by_s(record: dict, truth: dict) -> float:
    """When the camera has read a decoded PHY-SDU: the end of its last row's exposure, s."""
    last, k = int(record["last_row"]), int(truth.get("binning_rows", 1))  # a binned group starts with its first row
    return truth["start_s"] + float(last - last % k) * truth["row_time_s"] + truth["exposure_s"]


def _payload_bits(records: list[dict], payload_bits: int) -> np.ndarray:
    """The payloads of decoded records as a bool matrix (n, P)."""
    if not records:
        return np.zeros((0, payload_bits), dtype=bool)
    text = "".join(r["bits"] for r in records)
    return (np.frombuffer(text.encode("ascii"), dtype=np.uint8) == ord("1")).reshape(len(records), payload_bits)


def first_readings(sequences: np.ndarray, n_packets: int) -> np.ndarray:
    """Index of the first reading of each sequence number 0 … K−1 read, in sequence-number order.

    Numbers outside 0 … K−1 (possible only through an undetected error) are
    not packets of the message and are left out.
    """
    values, first = np.unique(sequences, return_index=True)
    return first[(values >= 0) & (values < n_packets)]


def decodable_at(sequences: np.ndarray, n_packets: int, strategy: str) -> int | None:
    """How many of the receptions (in order) make the message decodable, or None.

    Parameters
    ----------
    sequences : ndarray of int
        The sequence numbers (seeds, for rlnc) read, in reception order.
    n_packets : int
        K.
    strategy : {"rp", "rs", "rlnc"}
    """
    if sequences.size == 0:
        return None
    if strategy == "rlnc":
        return first_full_rank(combinations(sequences, n_packets))
    first = first_readings(sequences, n_packets)
    if first.size < n_packets:
        return None
    # The reception that brings the last missing sequence number.
    return int(first.max()) + 1


def receive_message(decoded: list[dict], truth: list[dict], transmitter) -> MessageReception:
    """Recover the message from the decoded PHY-SDUs, as a receiver would.

    Parameters
    ----------
    decoded : list of dict
        ``decoded.jsonl`` records (only those whose check passed are used),
        in the order read.
    truth : list of dict
        The frames' truth records (for their times).
    transmitter : Transmitter
        The message sent, its packets and strategy.
    """
    k = transmitter.n_packets
    strategy = transmitter.schedule.strategy
    payload_bits = transmitter.payloads.shape[1]
    used = [r for r in decoded if r["check_ok"] and len(r["bits"]) == payload_bits]
    sequences = np.array([r["sequence"] for r in used], dtype=np.int64)
    needed = decodable_at(sequences, k, strategy)
    if needed is None:
        return MessageReception(False, None, len(used), None, None, 0.0)
    head = used[:needed]
    bits = _payload_bits(head, payload_bits)
    if strategy == "rlnc":
        packets = eliminate(combinations(sequences[:needed], k), bits).solution
    else:
        packets = bits[first_readings(sequences[:needed], k)]
    message = depacketize(np.asarray(packets, dtype=np.uint8), len(transmitter.message))
    frame = int(head[-1]["frame"])
    by_frame = {t["frame"]: t for t in truth}
    duration = _read_by_s(head[-1], by_frame[frame]) - min(t["start_s"] for t in truth)
    goodput = 8.0 * len(transmitter.message) / duration if duration > 0 else 0.0
    return MessageReception(True, message == transmitter.message, needed, frame, duration, goodput)
