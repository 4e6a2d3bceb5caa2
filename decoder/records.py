"""What the decoder reports: one record per PHY-SDU, one result per frame.

Rows follow rollsim's convention: an instant t of frame k sits at the
fractional row (t − t_k − t_exp/2) / t_row, the row whose exposure window is
centred on it; that is where the profile crosses the midpoint at an edge.
"""

from __future__ import annotations

from dataclasses import dataclass, field

# Why a PHY-SDU candidate is or is not ok.
STATUSES = ("ok", "check_failed", "code_error", "erasure", "truncated")


@dataclass(frozen=True)
class DecodedPhySdu:
    """A PHY-SDU found in a frame.

    Attributes
    ----------
    frame : int
        Frame index.
    first_row_f : float
        Row position of the start of the SYNC's first chip.
    last_row_f : float
        Row position of the end of the PHY-SDU's last chip.
    sequence : int
        Sequence number from the header (meaningful only when ``check_ok``).
    bits : str
        Payload bits, e.g. ``"0101…"``, MSB first.
    check_ok : bool
        SYNC, line code and check bits all valid, no erased chip, and the
        whole PHY-SDU inside the LED's rows.
    confidence : float
        In [0, 1]: the smallest distance of a chip's sample from the
        threshold, as a fraction of half the local ON/OFF gap.
    status : str
        One of :data:`STATUSES`: ``ok``; ``check_failed`` (parity or CRC);
        ``code_error`` (an invalid Manchester pair or 4B6B word);
        ``erasure`` (a chip fell on a row without contrast); ``truncated``
        (runs past the LED's rows; reported only on request).
    region : int
        Which LED region of the frame (0 = the largest).
    """

    frame: int
    first_row_f: float
    last_row_f: float
    sequence: int
    bits: str
    check_ok: bool
    confidence: float
    status: str = "ok"
    region: int = 0

    @property
    def first_row(self) -> int:
        """``first_row_f`` rounded to the nearest row."""
        return int(round(self.first_row_f))

    @property
    def last_row(self) -> int:
        """``last_row_f`` rounded to the nearest row."""
        return int(round(self.last_row_f))

    def to_record(self) -> dict:
        """A JSON-ready dict (one line of ``decoded.jsonl``)."""
        return {
            "frame": int(self.frame),
            "first_row": self.first_row,
            "last_row": self.last_row,
            "first_row_f": round(float(self.first_row_f), 3),
            "last_row_f": round(float(self.last_row_f), 3),
            "sequence": int(self.sequence),
            "bits": self.bits,
            "check_ok": bool(self.check_ok),
            "confidence": round(float(self.confidence), 4),
            "status": self.status,
            "region": int(self.region),
        }


@dataclass(frozen=True)
class FrameDecode:
    """The decoder's result for one frame.

    Attributes
    ----------
    frame : int
        Frame index.
    source : str or None
        File name the frame came from, if any.
    sdus : tuple of DecodedPhySdu
    error : str or None
        Why the frame could not be decoded (unreadable file, bad shape);
        None when it was decoded (possibly with no PHY-SDU).
    """

    frame: int
    source: str | None = None
    sdus: tuple = field(default_factory=tuple)
    error: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    def to_records(self) -> list[dict]:
        """One record per PHY-SDU (see :meth:`DecodedPhySdu.to_record`)."""
        return [sdu.to_record() for sdu in self.sdus]

    def error_record(self) -> dict | None:
        """A JSON-ready error record, or None when the frame was decoded."""
        if self.error is None:
            return None
        return {"frame": int(self.frame), "source": self.source, "error": self.error}
