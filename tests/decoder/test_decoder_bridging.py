"""Joining a footprint's parts across a long exposure's flat band (decoder.bridging)."""

import numpy as np
import pytest

from decoder.bridging import Part, bridged, grown, lit_threshold

BACKGROUND, OFF, ON = 60.0, 62.0, 100.0
END_ROWS = 7


def striped(rows: int, cols: int) -> np.ndarray:
    """Block rows alternating between the ON and OFF levels, two at a time (stripes)."""
    levels = np.where((np.arange(rows) // 2) % 2 == 0, ON, OFF)
    return np.repeat(levels[:, None], cols, axis=1)


def frame_with_band(band_level: float, band_rows: int = 30, cols: int = 40, margin: int = 10):
    """Gray blocks: a striped part, a band at ``band_level``, another striped part, background around.

    Returns the image and the two parts as the region detector would find them.
    """
    top = 20
    gray = np.full((top + 2 * 40 + band_rows + 20, cols + 2 * margin), BACKGROUND)
    upper = slice(top, top + 40)
    lower = slice(upper.stop + band_rows, upper.stop + band_rows + 40)
    inside = slice(margin, margin + cols)
    gray[upper, inside] = striped(40, cols)
    gray[upper.stop : lower.start, inside] = band_level
    gray[lower, inside] = striped(40, cols)
    ones = np.ones((40, cols), np.uint8)
    return gray, [Part(ones, margin, upper.start, ones.size), Part(ones.copy(), margin, lower.start, ones.size)]


def test_the_threshold_is_midway_between_the_ends_mean_and_its_darkest_row():
    gray, (upper, _) = frame_with_band(BACKGROUND)
    threshold = lit_threshold(gray, slice(upper.y, upper.y + 8), slice(upper.x, upper.stop_col))
    assert threshold == pytest.approx(0.5 * ((ON + OFF) / 2 + OFF))


def test_a_band_at_the_leds_mean_level_joins_the_parts():
    """A run of equal bits under a two-chip exposure: flat, at the mean of ON and OFF."""
    gray, parts = frame_with_band(0.5 * (ON + OFF))
    found = bridged(gray, parts, max_gap=40, end_rows=END_ROWS)
    assert len(found) == 1
    (part,) = found
    assert (part.y, part.stop_row) == (parts[0].y, parts[1].stop_row)
    assert part.mask.all() and part.area == part.mask.size


@pytest.mark.parametrize("level", [BACKGROUND, OFF])
def test_a_gap_at_the_off_level_or_darker_stays_a_gap(level):
    """Two LEDs one above the other: between them the background, no brighter than their OFF stripes."""
    gray, parts = frame_with_band(level)
    found = bridged(gray, parts, max_gap=40, end_rows=END_ROWS)
    assert sorted((p.y, p.stop_row) for p in found) == sorted((p.y, p.stop_row) for p in parts)


def test_a_band_longer_than_both_reaches_is_not_crossed():
    """Each part grows by at most ``max_gap`` rows: 30 rows are crossed from both ends with 15, not with 14."""
    gray, parts = frame_with_band(0.5 * (ON + OFF), band_rows=30)
    assert len(bridged(gray, parts, max_gap=14, end_rows=END_ROWS)) == 2
    assert len(bridged(gray, parts, max_gap=15, end_rows=END_ROWS)) == 1


def test_no_reach_leaves_the_parts_alone():
    gray, parts = frame_with_band(0.5 * (ON + OFF))
    assert bridged(gray, parts, max_gap=0, end_rows=END_ROWS) is parts


def test_parts_side_by_side_are_never_joined():
    """Two LEDs in different columns, their rows overlapping, over a lit wall."""
    gray = np.full((100, 100), 0.5 * (ON + OFF))
    gray[10:50, 5:35] = striped(40, 30)
    gray[30:70, 60:90] = striped(40, 30)
    ones = np.ones((40, 30), np.uint8)
    parts = [Part(ones, 5, 10, ones.size), Part(ones.copy(), 60, 30, ones.size)]
    found = bridged(gray, parts, max_gap=40, end_rows=END_ROWS)
    assert sorted((p.x, p.stop_col) for p in found) == [(5, 35), (60, 90)]


def test_a_part_grows_to_the_frames_edge_over_a_lit_band_and_stops_at_a_dark_row():
    gray = np.full((100, 30), BACKGROUND)
    gray[0:12] = 0.5 * (ON + OFF)          # flat band at the frame's top
    gray[12:52] = striped(40, 30)
    gray[52:58] = 0.5 * (ON + OFF)         # flat band, then the background
    ones = np.ones((40, 30), np.uint8)
    part = grown(gray, Part(ones, 0, 12, ones.size), max_gap=40, end_rows=END_ROWS)
    assert (part.y, part.stop_row) == (0, 58)
    assert part.area == part.mask.size == 58 * 30


def test_growth_repeats_the_end_rows_mask():
    gray = np.full((60, 10), 0.5 * (ON + OFF))
    gray[20:40] = striped(20, 10)
    mask = np.zeros((20, 10), np.uint8)
    mask[:, 2:8] = 1
    part = grown(gray, Part(mask, 0, 20, int(mask.sum())), max_gap=5, end_rows=END_ROWS)
    assert (part.y, part.stop_row) == (15, 45)
    assert np.array_equal(part.mask[0], mask[0]) and np.array_equal(part.mask[-1], mask[-1])
    assert part.area == 30 * 6


@pytest.mark.parametrize("bridge", [False, True])
def test_a_rendered_footprint_split_by_a_flat_band_is_one_region(bridge):
    """paper-default at two chips of exposure, the frame whose dim top rim a flat band cuts off.

    Unbridged, the rows of its first PHY-SDU lie in no region whole; bridged,
    one region holds them, and the decoder reads that PHY-SDU.
    """
    from rollsim.stages.decode import settings_from_scene
    from rollsim.render import RenderPipeline
    from rollsim.scene import load_scene

    from decoder.pipeline import bridge_rows, closing_rows, decode_frame
    from decoder.region import block_means, detect_regions

    scene = load_scene("paper-default", ["camera.exposure_us=250", "camera.iso=4000", "seed=2770255956414847851"])
    settings = settings_from_scene(scene)
    frame = RenderPipeline(scene).render(9)
    first = next(s for s in frame.truth["sdus"] if s["first_row"] >= 0)
    assert first["first_row"] < 104 < 224 < first["last_row"]   # across the band
    pitch = 1.0 / (settings.clock_hz * settings.row_time_s)
    reach = bridge_rows(settings.phy, pitch, settings.exposure_s / settings.row_time_s) if bridge else 0.0
    regions = detect_regions(block_means(frame.image, 4), closing_rows(settings.phy, pitch), rows_per_chip=pitch,
                             bridge_rows=reach)
    holds = [r.rows.start <= first["first_row"] and r.rows.stop > first["last_row"] for r in regions]
    assert any(holds) == bridge
    if bridge:
        read = decode_frame(frame.image, settings.phy, settings.clock_hz, settings.row_time_s, 9,
                            exposure_s=settings.exposure_s)
        assert any(s.check_ok and s.sequence == first["sequence"] for s in read)
