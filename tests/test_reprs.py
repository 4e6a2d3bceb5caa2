"""The Python API's objects show themselves: a one-line repr of their key figures, and an HTML table for notebooks.

Each repr is checked against the object's own values, read back from the
line; the HTML table must carry the same figures, escaped. The objects
come from one small render (320x240, six frames) that decodes into a
message, so that every figure has a value to check.
"""

from __future__ import annotations

import html
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import rollsim as rs
from rollsim.sweeps import SweepResult
from rollsim.sweeps.table import columns_of

OVERRIDES = {"camera.width_px": 320, "camera.height_px": 240, "link.message_bytes": 4}
ROW = re.compile(r'<tr><th style="text-align:left">(.*?)</th><td style="text-align:left">(.*?)</td></tr>')


@pytest.fixture(scope="module")
def world():
    scene = rs.load_scene("paper-default", overrides=OVERRIDES)
    frames = rs.render(scene, n_frames=6, seed=2)
    result = rs.evaluate(frames.truth, rs.decode(frames))
    return SimpleNamespace(scene=scene, frames=frames, result=result, fit=rs.calibrate(result),
                           broadcast=rs.simulate(scene, runs=20, workers=1))


def shown(thing) -> tuple[str, dict[str, str]]:
    """The title and figures of ``thing``'s repr, after checking that its repr and HTML table agree."""
    line = repr(thing)
    assert "\n" not in line and len(line) < 400, line
    table = thing._repr_html_()
    assert table.startswith("<table><caption>") and table.endswith("</table>"), table
    caption = html.unescape(re.search(r"<caption>(.*?)</caption>", table).group(1))
    rows = [(html.unescape(label), html.unescape(value)) for label, value in ROW.findall(table)]
    assert rows, table
    # Nothing in the table but the caption and the rows: every value is escaped.
    assert re.sub(ROW, "", table) == f"<table><caption>{html.escape(caption)}</caption></table>"
    assert line == f"<{caption}: " + ", ".join(f"{label} {value}" for label, value in rows) + ">"
    kind, _, title = caption.partition(" ")
    assert kind == type(thing).__name__
    return title, dict(rows)


def number(text: str) -> float:
    """The number a figure starts with (``27.78 µs`` -> 27.78)."""
    return float(re.match(r"[-+0-9.e]+", text).group(0))


def close(text: str, value: float) -> bool:
    """Whether a figure shows ``value`` (to the four significant digits it is written with)."""
    return number(text) == pytest.approx(value, rel=1e-3, abs=1e-12)


def test_a_scene_shows_its_camera_timing_link_and_pattern(world):
    scene = world.scene
    title, figures = shown(scene)
    assert title == repr(scene.name) == "'paper-default'"
    assert figures["camera"] == f"{scene.camera.width_px}x{scene.camera.height_px} {scene.camera.output}" == "320x240 gray8"
    assert figures["row time"].endswith(" µs") and close(figures["row time"], scene.camera.row_time_s * 1e6)
    assert figures["exposure"] == f"{scene.camera.exposure_us:g} µs"
    assert figures["distance"] == f"{scene.link.distance_cm:g} cm"
    assert figures["clock"] == f"{scene.link.clock_hz:g} Hz"
    assert figures["pattern"] == f"data ({scene.link.strategy.upper()} r={scene.link.repeats})"
    # pydantic's str and repr list every field of every section; both are the line now.
    assert str(scene) == repr(scene)
    square = rs.load_scene(scene, overrides={"link.pattern": "square", "link.distance_cm": 12.5})
    assert shown(square)[1]["pattern"] == "square" and shown(square)[1]["distance"] == "12.5 cm"


def test_a_scene_name_is_escaped_in_the_table(world):
    scene = rs.load_scene(world.scene, overrides={"name": "<b>a & 'b'</b>"})
    table = scene._repr_html_()
    assert "<b>" not in table and "&lt;b&gt;a &amp; " in table
    assert shown(scene)[0] == repr("<b>a & 'b'</b>")


def test_frames_show_count_size_scene_and_seed_without_rendering():
    scene = rs.load_scene("paper-default", overrides=OVERRIDES)
    frames = rs.render(scene, n_frames=4, seed=7, start=3)
    title, figures = shown(frames)
    assert title == repr(frames.scene.name) == "'paper-default'"
    assert figures == {"count": "4 (from frame 3)", "size": "320x240 gray8", "seed": "7"}
    assert frames.scene.seed == 7
    # Cheap: showing them rendered nothing.
    assert frames._pipeline is None and frames._truth == {}


def test_a_frame_and_its_truth_show_image_phy_sdus_and_led_rows(world):
    frame = next(iter(world.frames))
    truth = frame.truth
    title, figures = shown(frame)
    assert title == str(frame.index) == "0"
    assert figures["image"] == f"{frame.image.shape[1]}x{frame.image.shape[0]} {frame.image.dtype}" == "320x240 uint8"
    visible = sum(sdu.fully_visible for sdu in truth.sdus)
    assert figures["PHY-SDUs"] == f"{len(truth.sdus)} ({visible} fully visible)"
    assert figures["LED rows"] == f"{truth.led_rows[0]}..{truth.led_rows[-1]}"
    assert "array" not in repr(frame)  # the image is not printed
    title, truth_figures = shown(truth)
    assert title == f"frame {truth.frame}"
    assert truth_figures["start"] == f"{truth.start_s:g} s"
    assert truth_figures["PHY-SDUs"] == figures["PHY-SDUs"] and truth_figures["LED rows"] == figures["LED rows"]


def test_a_colour_frame_shows_its_channels():
    truth = rs.FrameTruth(5, 0.25, 1e-5, 1e-4, None, ())
    frame = rs.Frame(5, np.zeros((4, 6, 3), np.uint16), truth)
    assert shown(frame)[1] == {"image": "6x4x3 uint16", "PHY-SDUs": "0 (0 fully visible)", "LED rows": "none"}


def test_the_truth_of_a_run_counts_emissions_once(world):
    truth = world.frames.truth
    title, figures = shown(truth)
    assert title == "'paper-default'"
    assert figures["frames"] == f"{len(truth)} ({truth[0].frame}..{truth[-1].frame})" == "6 (0..5)"
    assert int(figures["PHY-SDUs"]) == len({s.tx for f in truth for s in f.sdus}) == world.result.summary["emissions"]
    assert int(figures["fully visible"]) == world.result.summary["fully_visible"]


def test_a_result_shows_emissions_outcomes_and_goodput(world):
    result = world.result
    counts, message = result.counts, result.summary["message"]
    title, figures = shown(result)
    assert title == "'paper-default'"
    assert int(figures["PHY-SDUs emitted"]) == result.summary["emissions"] == len(result.outcomes)
    for name in ("ok", "missed", "corrupted", "undetected_error", "not_visible"):
        assert int(figures[name.replace("_", " ")]) == counts[name]
    assert counts["ok"] > 0 and counts["corrupted"] > 0  # both outcomes are shown, not only zeros
    assert message["decodable"] and figures["goodput"].endswith(" bit/s")
    assert close(figures["goodput"], message["goodput_bps"]) and message["goodput_bps"] > 0
    # Nothing decoded: every emission missed, and the message not decodable.
    nothing = shown(rs.evaluate(world.frames.truth, []))[1]
    assert nothing["ok"] == "0" and nothing["missed"] == str(result.summary["fully_visible"])
    assert nothing["goodput"] == "0 bit/s (message not decodable)"


def test_a_calibration_shows_p_e_with_its_interval_m_n_and_the_ge_figures(world):
    fit = world.fit
    title, figures = shown(fit)
    assert title == ""
    assert (int(figures["M"]), int(figures["N"]), int(figures["N_p"])) == (fit.mmbp.M, fit.mmbp.N, fit.mmbp.n_packets)
    low, high = fit.mmbp.fit.p_e_ci95
    assert fit.mmbp.fit.on_failures > 0  # so the figure is the estimate and its two-sided interval
    match = re.fullmatch(r"(\S+) \(95 % CI (\S+) \.\. (\S+)\)", figures["p_e"])
    assert match, figures["p_e"]
    assert [float(x) for x in match.groups()] == pytest.approx([fit.mmbp.p_e, low, high], rel=1e-3)
    assert close(figures["GE p"], fit.ge.p) and close(figures["GE q"], fit.ge.q) and close(figures["GE p_e"], fit.ge.p_e)
    assert figures["selected by BIC"] == fit.report["selected_by_bic"]
    # The dataclass's own repr would print all of calibration.json.
    assert "curves" not in repr(fit) and len(repr(fit)) < 250
    # The MMBP model alone: the same MMBP figures.
    mmbp = shown(fit.mmbp)[1]
    assert mmbp == {name: figures[name] for name in ("M", "N", "p_e", "N_p")}


def test_a_broadcast_shows_channel_strategy_runs_and_goodput(world):
    broadcast = world.broadcast
    _, figures = shown(broadcast)
    assert figures["channel"] == broadcast.channel["kind"] == "mmbp"
    assert figures["strategy"] == f"{broadcast.strategy.upper()} r={broadcast.repeats}"
    assert figures["N_p"] == str(broadcast.n_packets) and figures["seed"] == str(broadcast.seed)
    assert figures["runs"] == f"20 ({int(broadcast.completed.sum())} completed)"
    assert close(figures["mean goodput"], broadcast.summary()["metrics"]["goodput_bps"]["mean"])


def test_a_sweep_result_shows_stage_keys_cells_and_directory():
    rows = [{"status": "ok"}, {"status": "ok"}, {"status": "error"}]
    result = SweepResult(Path("runs/<sweep>"), rows, columns_of("analytic", ["link.distance_cm"]), computed=2,
                         failed=1, stage="analytic")
    title, figures = shown(result)
    assert title == "analytic stage"
    assert figures == {"over": "link.distance_cm", "cells": "3 (2 computed now)", "ok": "2", "failed": "1",
                       "in": "runs/<sweep>"}
    assert "runs/&lt;sweep&gt;" in result._repr_html_()
    # Without its stage, the keys cannot be told from the stage's columns: not shown.
    unstaged = SweepResult(Path("runs"), rows, result.columns, computed=3, failed=1)
    assert shown(unstaged) == ("", {"cells": "3 (3 computed now)", "ok": "2", "failed": "1", "in": "runs"})


@pytest.mark.parametrize("damage", ["scene", "summary", "fit"])
def test_a_repr_never_raises_it_shows_the_class_name(world, damage):
    # A half-built or damaged object (an attribute gone, a summary emptied)
    # still shows what it is: a repr that raises breaks a notebook's output.
    if damage == "scene":
        thing = rs.render(world.scene, n_frames=1)
        del thing.scene
    elif damage == "summary":
        thing = rs.evaluate(world.frames.truth, [])
        thing.summary = {}
    else:
        thing = rs.MmbpModel.__new__(rs.MmbpModel)  # no fields at all
    kind = type(thing).__name__
    assert repr(thing) == f"<{kind}>" and str(thing) == f"<{kind}>"
    assert thing._repr_html_() == f"<table><caption>{kind}</caption></table>"


def test_long_values_are_cut_to_one_short_line(world):
    scene = rs.load_scene(world.scene, overrides={"name": "x" * 5000 + "\nsecond line"})
    line = repr(scene)
    assert "\n" not in line and len(line) < 400 and "..." in line
