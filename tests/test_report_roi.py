"""The run report's ROI ratio and LED position, from the truth records."""

import math

import pytest

from rollsim.report import roi_figures


def test_roi_ratio_is_the_mean_share_of_rows_and_a_frame_without_the_led_counts_zero():
    truth = [{"led_rows": [0, 99]}, {"led_rows": [10, 59]}, {"led_rows": None}, {"led_rows": [0, 199]}]
    figures = roi_figures(truth, 200)
    assert figures["roi_ratio"] == pytest.approx((0.5 + 0.25 + 0.0 + 1.0) / 4)
    assert (figures["roi_min"], figures["roi_max"]) == (0.0, 1.0)
    assert figures["centre_std_px"] is None and figures["centre_range_px"] is None


def test_the_led_centre_spread_is_its_standard_deviation_and_largest_distance():
    # Centres on a square of side 2 about (100, 50): std 1 in x and y, each √2 from the mean.
    centres = [(99.0, 49.0), (101.0, 49.0), (99.0, 51.0), (101.0, 51.0)]
    truth = [{"led_rows": [0, 9], "led_centre_px": list(c)} for c in centres]
    figures = roi_figures(truth, 10)
    assert figures["roi_ratio"] == 1.0
    assert figures["centre_std_px"] == pytest.approx((1.0, 1.0))
    assert figures["centre_range_px"] == pytest.approx(math.sqrt(2.0))


def test_no_frames_give_a_zero_roi_not_a_warning():
    figures = roi_figures([], 1080)
    assert figures["roi_ratio"] == 0.0 and figures["centre_std_px"] is None
