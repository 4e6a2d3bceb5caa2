"""Ground truth of a rendered frame.

One record per frame: its index and start time, row time and exposure, the
LED's first and last row, and every emitted PHY-SDU that overlaps the frame's
capture span [t_k, t_k + (H−1)·t_row + t_exp].

A PHY-SDU is ``fully_visible`` when its whole time span lies inside
[start of the LED's first row, end of the LED's last row's exposure] of that
frame: every chip of it was integrated by some LED row.

Rows of a PHY-SDU spanning [a, b]:

``first_row``, ``last_row`` (integers)
    The first and last row whose exposure window lies wholly inside [a, b]:
    ceil((a − t_k)/t_row) and floor((b − t_exp − t_k)/t_row). These rows see
    this PHY-SDU and nothing else; for a fully visible PHY-SDU they lie inside
    the LED's rows. (If t_exp exceeds the PHY-SDU, first_row > last_row.)
``first_row_f``, ``last_row_f`` (floats)
    The rows centred on a and on b, (t − t_k − t_exp/2)/t_row: where a
    decoder sees the PHY-SDU's first and last stripe edges
    (:meth:`rollsim.sensor.RowTiming.row_of_time`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup


def _bit_strings(bits: np.ndarray) -> list[str]:
    return ["".join("1" if b else "0" for b in row) for row in bits.tolist()]


def frame_truth(setup: SceneSetup, index: int, start_s: float, led_rows=None, led_centre_px=None) -> dict:
    """The truth record of frame ``index`` starting at ``start_s``.

    Parameters
    ----------
    setup : SceneSetup
    index : int
    start_s : float
        Actual frame start (with jitter, when that effect is on).
    led_rows : (int, int), () or None, optional
        The LED's rows in this frame (``()``: none); None means the setup's.
    led_centre_px : (float, float) or None, optional
        Where the frame shows the LED's centre (x, y), px, when the LED
        moves (``motion``); recorded as ``led_centre_px`` only then, so a
        still scene's truth keeps its bytes.
    """
    timing, tx = setup.timing, setup.transmitter
    led_rows = setup.led_rows if led_rows is None else led_rows
    span_end = start_s + (timing.height_px - 1) * timing.row_time_s + timing.exposure_s
    record = {
        "frame": int(index),
        "start_s": float(start_s),
        "row_time_s": float(timing.row_time_s),
        "exposure_s": float(timing.exposure_s),
        "led_rows": list(led_rows) if led_rows else None,
        "sdus": [],
    }
    if led_centre_px is not None:
        record["led_centre_px"] = [float(v) for v in led_centre_px]
    if timing.binning_rows > 1:  # written only when binned, so unbinned truth files keep their bytes
        record["binning_rows"] = int(timing.binning_rows)
    emissions = tx.emissions_between(start_s, span_end)
    if emissions.size == 0:
        return record
    starts = tx.emission_start_s(emissions)
    ends = starts + tx.sdu_duration_s
    first = timing.row_of_time(starts, start_s)
    last = timing.row_of_time(ends, start_s)
    # A row's window starts with its group's (k rows read as one; k = 1 unbinned).
    k, group_time = timing.binning_rows, timing.binning_rows * timing.row_time_s
    inner_first = k * np.ceil((starts - start_s) / group_time - 1e-9).astype(np.int64)
    inner_last = k * np.floor((ends - timing.exposure_s - start_s) / group_time + 1e-9).astype(np.int64) + k - 1
    if led_rows:
        visible_from, visible_to = timing.rows_span_s(led_rows[0], led_rows[1], start_s)
        fully = (starts >= visible_from) & (ends <= visible_to)
    else:
        fully = np.zeros(emissions.size, dtype=bool)
    sequence = tx.schedule.sequence_numbers(emissions)
    codewords = tx.codeword_bits(emissions)
    phy = tx.phy
    payload = _bit_strings(codewords[:, phy.header_bits : phy.data_bits])
    codeword = _bit_strings(codewords)
    record["sdus"] = [
        {
            "tx": int(emissions[i]),
            "sequence": int(sequence[i]),
            "bits": payload[i],
            "codeword": codeword[i],
            "start_s": float(starts[i]),
            "end_s": float(ends[i]),
            "first_row": int(inner_first[i]),
            "last_row": int(inner_last[i]),
            "first_row_f": float(first[i]),
            "last_row_f": float(last[i]),
            "fully_visible": bool(fully[i]),
        }
        for i in range(emissions.size)
    ]
    return record
