"""Frame metadata in PNG text chunks: written by every render, read back exactly."""

import io

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from rollsim.cli import main
from rollsim.protocol.png_text import add_png_text, read_png_text
from rollsim.render.png import encode_png
from rollsim.scene import load_scene

IMAGE = (np.arange(30 * 40) % 251).astype(np.uint8).reshape(30, 40)


def test_text_chunks_round_trip_and_leave_the_image_alone():
    entries = {"exposure_us": "100.0", "Software": "rollsim", "note": "ISO 10000 µ"}
    png = encode_png(IMAGE, entries)
    assert read_png_text(png) == entries
    assert np.array_equal(cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED), IMAGE)
    # Pillow checks every chunk's CRC as it reads.
    with Image.open(io.BytesIO(png)) as image:
        assert image.text == entries and np.array_equal(np.asarray(image), IMAGE)


@settings(max_examples=50, deadline=None)
@given(st.dictionaries(st.text(st.characters(min_codepoint=33, max_codepoint=255, blacklist_characters="\x7f"), min_size=1,
                               max_size=20),
                       st.text(st.characters(min_codepoint=1, max_codepoint=255), max_size=40), max_size=5))
def test_any_latin1_entries_round_trip(entries):
    assert read_png_text(add_png_text(encode_png(IMAGE), entries)) == entries


@pytest.mark.parametrize("keyword", ["", " lead", "x" * 80, "nul\x00"])
def test_a_bad_keyword_is_refused(keyword):
    with pytest.raises(ValueError, match="PNG text keyword"):
        add_png_text(encode_png(IMAGE), {keyword: "1"})


def test_not_a_png_is_refused():
    with pytest.raises(ValueError, match="not a PNG"):
        add_png_text(b"GIF89a", {"a": "1"})
    with pytest.raises(ValueError, match="not a PNG"):
        read_png_text(b"\x00" * 64)


def test_a_truncated_file_gives_what_it_holds():
    png = add_png_text(encode_png(IMAGE), {"a": "1", "b": "2"})
    first_end = 33 + 12 + len(b"a\x001")
    assert read_png_text(png[: first_end + 5]) == {"a": "1"}


def test_every_rendered_frame_says_its_camera_settings(tmp_path):
    out = tmp_path / "run"
    overrides = ["camera.width_px=64", "camera.height_px=48", "camera.identity_seed=9"]
    args = ["render", "paper-geometric", "--frames", "3", "--out", str(out), "--quiet", "--seed", "4"]
    assert main(args + [a for o in overrides for a in ("--set", o)]) == 0
    scene = load_scene("paper-geometric", overrides)
    cam = scene.camera
    for k in range(3):
        text = read_png_text((out / "frames" / f"frame_{k:06d}.png").read_bytes())
        assert int(text["frame"]) == k and float(text["start_s"]) == k * cam.frame_period_s
        assert float(text["row_time_us"]) == cam.row_time_s * 1e6 and float(text["exposure_us"]) == cam.exposure_us
        assert float(text["gain_dn_per_e"]) == cam.gain_dn_per_e_at_iso and int(text["black_level_dn"]) == 64
        assert (text["seed"], text["identity_seed"], text["output"]) == ("4", "9", "gray8")
