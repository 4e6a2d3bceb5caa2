"""decoder.rowtime refuses every code that is not a square wave.

A generated family of the codes OCC links send (pulse-length codes whose OFF
gaps are a few rows and whose ON runs vary several-fold, PWM at a fixed
period, codes that repeat every few hundred rows), seen through a rolling
shutter's box and an ISP's blur, with noise, as grey, colour (one channel
carrying the light) and single-channel frames: none gets a row time.
"""

import time

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from synth import profile_from_chips

from decoder import RowTimeError, estimate_row_time
from rollsim.fit.stripes import box_level_range

# The family's ranges, in rows.
ON_ROWS = (3, 40)
GAP_ROWS = (2, 8)
PWM_PERIOD_ROWS = (12, 80)
EXPOSURE_CHIPS = (0.2, 4.0)


def pulse_length_runs(rng, rows: int) -> list[int]:
    """ON runs that vary several-fold (the shortest and a run ≥ 2× it in every word) and short OFF gaps."""
    short = int(rng.integers(ON_ROWS[0], ON_ROWS[1] // 3 + 1))
    word = [short, int(rng.integers(GAP_ROWS[0], GAP_ROWS[1] + 1)),
            int(rng.integers(2 * short, ON_ROWS[1] + 1)), int(rng.integers(GAP_ROWS[0], GAP_ROWS[1] + 1))]
    while sum(word) < int(rng.integers(40, 400)):  # words of 40 to 400 rows
        word += [int(rng.integers(short, ON_ROWS[1] + 1)), int(rng.integers(GAP_ROWS[0], GAP_ROWS[1] + 1))]
    order = rng.permutation(len(word) // 2)
    word = [word[2 * i + j] for i in order for j in (0, 1)]
    if rng.random() < 0.5:  # the word repeats (a beacon) or runs on at random
        return word * (rows // sum(word) + 3)
    runs = []
    while sum(runs) < rows + 400:
        runs += [int(rng.choice(word[0::2])), int(rng.integers(GAP_ROWS[0], GAP_ROWS[1] + 1))]
    return runs


def pwm_runs(rng, rows: int) -> list[int]:
    """PWM at a fixed period: ON widths from 15 % to 85 % of it, each period's
    differing from the last by at least a third (runs of one width are a
    square wave of another duty, which the estimator may read)."""
    period = int(rng.integers(*PWM_PERIOD_ROWS))
    runs: list[int] = []
    on = 0.5
    while sum(runs) < rows + 2 * period:
        on = float(rng.choice([f for f in np.linspace(0.15, 0.85, 15) if abs(f - on) >= 0.34 * on]))
        width = max(1, int(round(period * on)))
        runs += [width, max(1, period - width)]
    return runs


def code_frames(seed: int, kind: str, layout: str, n: int = 3) -> list[np.ndarray]:
    """``n`` frames of one code (``pulse`` or ``pwm``) as ``grey``, ``colour`` or ``channel`` frames."""
    rng = np.random.default_rng(seed)
    rows, cols = int(rng.integers(300, 1081)), int(rng.integers(16, 161))
    exposure_rows, blur_rows = float(rng.uniform(0.3, 3.0)), float(rng.uniform(0.0, 1.5))
    on, off, noise = float(rng.uniform(60, 250)), float(rng.uniform(0, 50)), float(rng.uniform(0, 8))
    weights = rng.dirichlet([1.0, 1.0, 1.0]) if layout == "colour" else None
    runs = (pulse_length_runs if kind == "pulse" else pwm_runs)(rng, rows)
    chips = np.repeat(np.arange(len(runs)) % 2 == 0, runs).astype(float)
    frames = []
    for _ in range(n):
        start = int(rng.integers(0, max(1, chips.size - rows - 10)))
        values = profile_from_chips(chips[start:start + rows + 10], 1.0, exposure_rows, on=on, off=off)[:rows]
        if blur_rows > 0.05:
            values = cv2.GaussianBlur(values.reshape(-1, 1), (1, 0), sigmaX=0.1, sigmaY=blur_rows).ravel()
        image = values[:, None] + rng.normal(0.0, noise, (values.size, cols))
        if layout == "colour":
            image = np.stack([image * w * 3 for w in weights], axis=2)
        elif layout == "channel":
            image = np.stack([image, np.zeros_like(image), np.zeros_like(image)], axis=2)
        frames.append(np.clip(np.rint(image), 0, 255).astype(np.uint8))
    return frames


@settings(max_examples=200, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(["pulse", "pwm"]),
       layout=st.sampled_from(["grey", "colour", "channel"]), clock_hz=st.sampled_from([1000.0, 4000.0, 8000.0]))
# Codes whose word is four periods of a square wave with a few rows' duty
# jitter, one ON run split by a gap of 2-3 rows or a 5-row pulse once a
# word: found by unseeded runs of 2000 examples, and once given a row time.
@example(seed=31534, kind="pulse", layout="colour", clock_hz=1000.0)
@example(seed=3000791, kind="pulse", layout="grey", clock_hz=1000.0)
# ON runs of 34-42 rows between gaps of 7-11, unclipped, lined up in one
# frame of three: read at 46 rows a period by a second spectral guess made
# where the plateaus do not clip.
@example(seed=859, kind="pulse", layout="colour", clock_hz=1000.0)
# ON runs of 33-40 rows between gaps of 2-8 lined up at a period of 41 rows
# in one frame of three (found by an unseeded run of 3000 examples).
@example(seed=1647188821, kind="pulse", layout="channel", clock_hz=1000.0)
def test_no_code_but_a_square_wave_gets_a_row_time(seed, kind, layout, clock_hz):
    frames = code_frames(seed, kind, layout)
    with pytest.raises(RowTimeError):
        estimate_row_time(frames, clock_hz)


def test_the_issue_pulse_length_code_is_refused_in_grey_and_colour_within_5_s(tmp_path, capsys):
    # ON runs of 7 to 26 rows, OFF gaps of 3 to 6, the word repeating every
    # ~124 rows, the red channel carrying it: once read as a 0.9 µs row time.
    from rollsim.cli import main

    word = [7, 3, 26, 4, 12, 6, 19, 3, 9, 5, 22, 4, 7, 3]
    assert 115 <= sum(word) <= 130
    chips = np.repeat(np.arange(len(word) * 12) % 2 == 0, word * 12).astype(float)
    rng = np.random.default_rng(5)
    for layout in ("grey", "colour", "red"):
        folder = tmp_path / layout
        folder.mkdir()
        for i in range(4):
            start = int(rng.integers(0, 124))
            values = profile_from_chips(chips[start:start + 900], 1.0, 1.2, on=200.0, off=15.0)[:864]
            grey = values[:, None] + rng.normal(0, 3, (864, 16))
            image = {"grey": grey, "colour": np.stack([0.3 * grey, 0.4 * grey, grey], axis=2),  # BGR on disk
                     "red": np.stack([np.zeros_like(grey), np.zeros_like(grey), grey], axis=2)}[layout]
            cv2.imwrite(str(folder / f"{i:03d}.png"), np.clip(image, 0, 255).astype(np.uint8))
        started = time.perf_counter()
        assert main(["estimate-row-time", str(folder), "--clock-hz", "8000"]) == 2
        assert time.perf_counter() - started < 5.0
        assert "no frame shows a square-wave LED" in capsys.readouterr().err


def square_frames(seed: int, layout: str, n: int = 3) -> tuple[list[np.ndarray], float, bool]:
    """``n`` frames of the square pattern (ON one chip, OFF the next), their period in rows, and
    whether they hold stripes at all.

    1.5 to 20 rows a chip, exposure 0.2 to 4 chips, the ON level 0.3 to 30
    full scales (clipped), a tone curve, blur and noise. A row's level runs
    over off + on × :func:`rollsim.fit.stripes.box_level_range`; the frames
    hold stripes when the lower bound is below 0.9 full scale and the two,
    clipped at full scale, differ by 5 % of it.
    """
    rng = np.random.default_rng(seed)
    rows, cols = int(rng.integers(300, 1081)), int(rng.integers(16, 161))
    rows_per_chip = float(rng.uniform(1.5, 20.0))
    exposure_chips = float(rng.uniform(*EXPOSURE_CHIPS))
    on_full_scales, off = float(np.exp(rng.uniform(np.log(0.3), np.log(30.0)))), float(rng.uniform(0.0, 0.2))
    gamma, blur_rows, noise = float(rng.choice([1.0, 2.2])), float(rng.uniform(0.0, 1.0)), float(rng.uniform(0, 4))
    weights = rng.dirichlet([1.0, 1.0, 1.0]) + 0.2 if layout == "colour" else None
    least, most = box_level_range(exposure_chips)
    low, high = off + on_full_scales * least, off + on_full_scales * most
    readable = bool(low < 0.9 and min(high, 1.0) - min(low, 1.0) > 0.05)
    chips = np.tile([1.0, 0.0], rows)
    frames = []
    for _ in range(n):
        phase = float(rng.uniform(0.0, 2.0))
        linear = profile_from_chips(chips, rows_per_chip, exposure_chips * rows_per_chip, phase,
                                    on=on_full_scales, off=off)[:rows]
        values = 255.0 * np.clip(linear, 0.0, 1.0) ** (1.0 / gamma)
        if blur_rows > 0.05:
            values = cv2.GaussianBlur(values.reshape(-1, 1), (1, 0), sigmaX=0.1, sigmaY=blur_rows).ravel()
        image = values[:, None] + rng.normal(0.0, noise, (values.size, cols))
        if layout == "colour":
            image = np.stack([image * w for w in weights], axis=2)
        frames.append(np.clip(np.rint(image), 0, 255).astype(np.uint8))
    return frames, 2.0 * rows_per_chip, readable


@pytest.mark.parametrize("layout", ["grey", "colour"])
def test_square_waves_keep_their_row_time(layout):
    # Every answer within 0.5 %; of the sets that hold stripes, at least
    # 95 % answered (measured: 70 of 72 in grey over seeds 0-119; the two
    # refused are 14 and 27 full scales, one with a 4.6-row period).
    clock_hz = 4000.0
    answered, readable_sets = 0, 0
    for seed in range(60):
        frames, period_rows, readable = square_frames(seed, layout)
        try:
            row_time_s, _ = estimate_row_time(frames, clock_hz)
        except RowTimeError:
            readable_sets += readable
            continue
        assert row_time_s == pytest.approx(2.0 / clock_hz / period_rows, rel=0.005), seed
        answered += readable
        readable_sets += readable
    assert readable_sets >= 30 and answered >= 0.95 * readable_sets
