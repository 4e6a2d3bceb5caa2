"""Frames through a real encoder and decoder (PyAV's FFmpeg): known answers and bad input."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rollsim.errors import RollsimError
from rollsim.video.read import count_video_frames, probe_video, read_video_frames
from rollsim.video.settings import VideoSettings, parse_bitrate
from rollsim.video.write import VideoWriter

H, W = 96, 128


def _grey(n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 256, (H, W), dtype=np.uint8) for _ in range(n)]


def _colour(n: int, seed: int = 1) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 256, (H, W, 3), dtype=np.uint8) for _ in range(n)]


def _write(path, frames, settings, colour=False, metadata=None):
    with VideoWriter(path, settings, W, H, 30.0, colour, metadata) as writer:
        for frame in frames:
            writer.write(frame)


@pytest.mark.parametrize("container,chroma", [("mp4", "420"), ("mkv", "444"), ("mp4", "gray")])
def test_grey_frames_come_back_exact_when_lossless(tmp_path, container, chroma):
    frames = _grey(6)
    path = tmp_path / f"v.{container}"
    _write(path, frames, VideoSettings(container=container, crf=0, chroma=chroma), metadata={"output": "gray8"})
    back = list(read_video_frames(path))
    assert len(back) == len(frames)
    for a, b in zip(back, frames):
        assert a.shape == b.shape and a.dtype == np.uint8
        # Grey frames are coded as full-range luma: every level has its code.
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("codec", ["h264", "hevc"])
def test_colour_444_is_exact_when_lossless(tmp_path, codec):
    frames = _colour(4)
    path = tmp_path / "v.mkv"
    _write(path, frames, VideoSettings(container="mkv", codec=codec, crf=0, chroma="444"), colour=True)
    back = list(read_video_frames(path))
    assert max(int(np.abs(a.astype(int) - b).max()) for a, b in zip(back, frames)) <= 1


def test_colour_420_loses_only_what_chroma_subsampling_drops(tmp_path):
    """Grey detail on one colour (R, G, B = g + a constant offset: Cb and Cr the same
    everywhere) survives 4:2:0, Y'CbCr rounding aside (2 levels); the colour of
    pixel noise does not (its chroma is filtered to half the resolution)."""
    rng = np.random.default_rng(2)
    offset = np.array([30, 0, -20])
    smooth = [(rng.integers(40, 200, (H, W, 1)) + offset).astype(np.uint8) for _ in range(3)]
    noisy = _colour(3)
    path = tmp_path / "v.mp4"
    _write(path, smooth + noisy, VideoSettings(crf=0), colour=True)
    back = list(read_video_frames(path))
    assert max(int(np.abs(a.astype(int) - b).max()) for a, b in zip(back[:3], smooth)) <= 2
    assert min(int(np.abs(a.astype(int) - b).max()) for a, b in zip(back[3:], noisy)) > 20


def test_frame_order_range_and_count(tmp_path):
    frames = _grey(9)
    path = tmp_path / "v.mp4"
    _write(path, frames, VideoSettings(crf=0), metadata={"output": "gray8", "scene": "s", "seed": "7"})
    info = probe_video(path)
    assert (info.width_px, info.height_px, info.frames, info.grey) == (W, H, 9, True)
    assert info.metadata["scene"] == "s" and info.metadata["seed"] == "7"
    assert count_video_frames(path) == 9
    picked = list(read_video_frames(path, start=3, count=4))
    assert len(picked) == 4
    for a, b in zip(picked, frames[3:7]):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(RollsimError, match="holds 9 frames"):
        list(read_video_frames(path, start=5, count=10))


def test_rotate_turns_frames_clockwise(tmp_path):
    frames = _grey(2)
    path = tmp_path / "v.mp4"
    _write(path, frames, VideoSettings(crf=0), metadata={"output": "gray8"})
    turned = next(read_video_frames(path, rotate_deg=90))
    upright = next(read_video_frames(path))
    assert turned.shape == (W, H)
    assert np.array_equal(turned, np.rot90(upright, k=-1))


def test_bad_files_are_refused_in_one_line(tmp_path):
    text = tmp_path / "notes.mp4"
    text.write_text("not a video at all\n" * 50)
    with pytest.raises(RollsimError, match="not a video file") as err:
        probe_video(text)
    assert "\n" not in str(err.value)
    with pytest.raises(RollsimError, match="no such video file"):
        probe_video(tmp_path / "missing.mp4")
    good = tmp_path / "v.mkv"
    _write(good, _grey(30), VideoSettings(container="mkv", crf=0), metadata={"output": "gray8"})
    data = good.read_bytes()
    cut = tmp_path / "cut.mkv"
    cut.write_bytes(data[: len(data) // 3])
    assert count_video_frames(cut) < 30  # Matroska streams: what is left reads
    with pytest.raises(RollsimError, match="cut.mkv: holds .* frames; frames 0 to 29 were asked for"):
        list(read_video_frames(cut, count=30))
    # An MP4's index (moov) follows its data: cut short, nothing reads.
    mp4 = tmp_path / "v.mp4"
    _write(mp4, _grey(30), VideoSettings(crf=0), metadata={"output": "gray8"})
    short = tmp_path / "cut.mp4"
    short.write_bytes(mp4.read_bytes()[: mp4.stat().st_size // 2])
    with pytest.raises(RollsimError, match="cut.mp4: not a video file"):
        probe_video(short)


def test_ten_bit_video_is_refused(tmp_path):
    import av

    path = tmp_path / "deep.mkv"
    with av.open(str(path), "w", format="matroska") as container:
        stream = container.add_stream("libx264", rate=30)
        stream.width, stream.height, stream.pix_fmt = W, H, "yuv420p10le"
        for _ in range(2):
            frame = av.VideoFrame.from_ndarray(np.zeros((H, W), np.uint8), format="gray").reformat(format="yuv420p10le")
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    with pytest.raises(RollsimError, match="yuv420p10le.*8-bit"):
        probe_video(path)


@pytest.mark.parametrize("kwargs,field", [
    ({"container": "avi"}, "--container"), ({"codec": "vp9"}, "--codec"), ({"crf": 60}, "--crf"),
    ({"crf": 20, "bitrate_bps": 10**6}, "--crf and --bitrate"), ({"gop_frames": 0}, "--gop"),
    ({"preset": "warp"}, "--preset"), ({"chroma": "422"}, "--chroma"),
])
def test_impossible_settings_name_their_option(kwargs, field):
    with pytest.raises(RollsimError, match=field):
        VideoSettings(**kwargs)


def test_bitrates_parse_with_units():
    assert parse_bitrate("17M") == 17_000_000
    assert parse_bitrate("800k") == 800_000
    assert parse_bitrate("2.5M") == 2_500_000
    for bad in ("fast", "-3M", "5G", ""):
        with pytest.raises(RollsimError, match="--bitrate"):
            parse_bitrate(bad)


def test_encoded_size_follows_the_bitrate(tmp_path):
    """Rate control: 30 noisy frames (one second) at 2 Mb/s take about 250 kB."""
    frames = _grey(30, seed=3)
    path = tmp_path / "v.mp4"
    _write(path, frames, VideoSettings(bitrate_bps=2_000_000), metadata={"output": "gray8"})
    assert 0.5 * 250_000 < path.stat().st_size < 2.0 * 250_000


def _write_turned(path, frames, counterclockwise_deg: int) -> None:
    """Frames stored turned, with the display matrix that turns them back (a phone's portrait recording)."""
    import av

    h, w = frames[0].shape
    with av.open(str(path), "w", format="mp4") as container:
        stream = container.add_stream("libx264", rate=30)
        stream.width, stream.height, stream.pix_fmt = w, h, "gray"
        stream.options = {"crf": "0"}
        stream.codec_context.color_range = 2
        stream.set_display_rotation(counterclockwise_deg)
        for i, image in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(image, format="gray")
            frame.pts, frame.color_range = i, 2
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


@pytest.mark.parametrize("quarter_turns", [1, 2, 3])
def test_portrait_recordings_are_read_upright(tmp_path, quarter_turns):
    upright = _grey(3)
    stored = [np.ascontiguousarray(np.rot90(f, k=-quarter_turns)) for f in upright]  # turned clockwise
    path = tmp_path / "portrait.mp4"
    _write_turned(path, stored, 90 * quarter_turns)  # shown turned back, counterclockwise
    assert probe_video(path).rotation_deg == (360 - 90 * quarter_turns) % 360
    for a, b in zip(read_video_frames(path), upright, strict=True):
        # A file rollsim did not write is read as RGB: its grey comes as three equal channels.
        assert np.array_equal(a, np.stack([b] * 3, axis=-1))
    # --rotate overrides the container: 0 keeps the frames as stored.
    assert np.array_equal(next(read_video_frames(path, rotate_deg=0))[..., 0], stored[0])


def _striped(n: int, turned: bool) -> list[np.ndarray]:
    """Frames of moving rolling-shutter stripes (a level per row), stored turned a quarter counterclockwise."""
    rng = np.random.default_rng(4)
    rows = np.arange(H)[:, None]
    frames = []
    for t in range(n):
        image = 128 + 60 * np.sign(np.sin(2 * np.pi * (rows + 7 * t) / 20.0)) + rng.normal(0, 3, (H, W))
        image = np.clip(np.rint(image), 0, 255).astype(np.uint8)
        frames.append(np.ascontiguousarray(np.rot90(image)) if turned else image)
    return frames


def test_stripes_along_the_columns_are_turned_upright_and_said(tmp_path):
    """No rotation in the file, stripes along the columns: the frames are turned a quarter
    clockwise (the stripes then run along the rows) and a note says so; upright ones are kept."""
    from rollsim.video.read import stripes_run_along_columns

    upright = _striped(4, turned=False)
    stored = _striped(4, turned=True)
    assert stripes_run_along_columns(*stored[:2]) and not stripes_run_along_columns(*upright[:2])
    for name, frames, turned in (("side.mp4", stored, True), ("up.mp4", upright, False)):
        path = tmp_path / name
        h, w = frames[0].shape
        with VideoWriter(path, VideoSettings(crf=0, chroma="gray"), w, h, 30.0, False, {"output": "gray8"}) as writer:
            for frame in frames:
                writer.write(frame)
        notes: list[str] = []
        back = list(read_video_frames(path, notes=notes))
        expected = [np.rot90(f, k=-1) for f in frames] if turned else frames
        assert all(np.array_equal(a, b) for a, b in zip(back, expected, strict=True))
        assert bool(notes) == turned and (not turned or "stripes run along the columns" in notes[0])
        # --rotate 0 keeps them as stored, without a guess.
        assert np.array_equal(next(read_video_frames(path, rotate_deg=0)), frames[0])


@pytest.mark.parametrize("held,expected", [(6, 6), (12, 10)])
def test_fit_cameras_default_reads_at_most_ten_frames(tmp_path, held, expected):
    """fit-camera without --frames reads the first 10 frames of a video, or all of a shorter one."""
    import argparse

    from rollsim.cli import VIDEO_FIT_FRAMES, _video_input_frames

    path = tmp_path / "v.mp4"
    _write(path, _grey(held), VideoSettings(crf=0), metadata={"output": "gray8"})
    args = argparse.Namespace(video_frames=None, start=0, rotate=None)
    assert VIDEO_FIT_FRAMES == 10
    assert len(list(_video_input_frames(path, args, VIDEO_FIT_FRAMES, []))) == expected


def test_a_recording_without_rollsims_tags_is_redone_as_a_phone_codes(tmp_path):
    """Another encoder's file: bitrate from its size, GOP from its key frames, B-frames if the stream
    has them (x264's default count), rollsim's default tuning; rollsim's tags are not there to read."""
    from rollsim.video.read import recording_settings
    from rollsim.video.settings import DEFAULT_TUNE

    base = _grey(1)[0]
    frames = [np.roll(base, i, axis=0) for i in range(12)]  # a still scene panning: no scene cut
    for name, b_frames in (("p.mp4", 0), ("b.mp4", 2)):
        _write(tmp_path / name, frames, VideoSettings(bitrate_bps=400_000, gop_frames=4, b_frames=b_frames,
                                                      tune="fastdecode"))
    plain, with_b = recording_settings(tmp_path / "p.mp4"), recording_settings(tmp_path / "b.mp4")
    assert plain.tune == with_b.tune == DEFAULT_TUNE == "none"
    assert (plain.b_frames, with_b.b_frames) == (0, 3)
    assert plain.gop_frames == 4 and plain.bitrate_bps != 400_000



def test_a_description_reads_back_as_its_settings():
    """The encoding tag a render writes (VideoSettings.describe with the frame rate) names its settings."""
    from rollsim.video.settings import described_settings

    for settings in (VideoSettings(), VideoSettings(crf=0, preset="medium", tune="fastdecode", b_frames=2),
                     VideoSettings(bitrate_bps=500_000, gop_frames=7, chroma="444")):
        given = VideoSettings(container=settings.container, codec=settings.codec, chroma=settings.chroma,
                              **described_settings(settings.describe(30.0)))
        assert given == replace(settings, gop_frames=settings.gop_for(30.0),
                                bitrate_bps=settings.bitrate_bps or (None if settings.crf is not None else 17_000_000))
    assert described_settings("h264 17 Mb/s preset nosuch tune none b-frames 0 chroma 420 gop 30") == {}
    assert described_settings(VideoSettings().describe()) == {}  # without a GOP: not a tag
