"""effects.video_codec: the render's frames through the real encoder and decoder, a GOP at a time."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from rollsim.errors import SceneError
from rollsim.render import RenderPipeline, render_frames
from rollsim.render.writer import render_to_dir
from rollsim.scene import load_scene

SMALL = ["camera.width_px=160", "camera.height_px=120", "camera.row_time_us=200"]


def _scene(*codec: str, extra=()):
    return load_scene("paper-default", [*SMALL, *extra, *(f"effects.video_codec.{c}" for c in codec)])


def test_lossless_coding_keeps_the_frames_within_a_level():
    """Known answer: at crf 0 the codec changes a grey frame by the rounding of limited-range Y' only."""
    plain, _ = render_frames(load_scene("paper-default", SMALL), 5)
    coded, _ = render_frames(_scene("crf=0", "gop_frames=5"), 5)
    for a, b in zip(coded, plain, strict=True):
        assert a.dtype == np.uint8 and a.shape == b.shape
        assert np.abs(a.astype(int) - b).max() <= 1


def test_fewer_bits_lose_more():
    plain, _ = render_frames(load_scene("paper-default", SMALL), 6)
    errors = []
    for bitrate in ("2e5", "2e6", "2e7"):
        coded, _ = render_frames(_scene(f"bitrate_bps={bitrate}", "gop_frames=6"), 6)
        errors.append(np.mean([np.abs(a.astype(float) - b).mean() for a, b in zip(coded, plain)]))
    assert errors[0] > errors[1] > errors[2] > 0, errors


def test_a_frame_depends_only_on_its_gop():
    """Frame 5 rendered alone (its GOP of 3 coded again from frame 3) is the one of the whole sequence."""
    scene = _scene("gop_frames=3", "bitrate_bps=1e6")
    sequence, truth = render_frames(scene, 7)
    alone = RenderPipeline(scene).render(5)
    assert np.array_equal(alone.image, sequence[5])
    assert alone.truth == truth[5]


def test_workers_write_the_same_bytes(tmp_path):
    """GOPs of 3 over 7 frames: chunks start on key frames, whatever the workers."""
    scene = _scene("gop_frames=3", "bitrate_bps=1e6")
    digests = []
    for workers in (1, 2):
        render_to_dir(scene, tmp_path / str(workers), 7, workers=workers)
        digests.append({p.name: hashlib.sha256(p.read_bytes()).hexdigest()
                        for p in sorted((tmp_path / str(workers)).rglob("*")) if p.is_file()})
    assert digests[0] == digests[1]


@pytest.mark.parametrize("overrides,field", [
    (["effects.video_codec.crf=20", "effects.video_codec.bitrate_bps=1e6"], "crf or bitrate_bps"),
    (["camera.output=raw16", "effects.video_codec=null"], "effects.video_codec: acts on 8-bit output"),
    (["camera.width_px=161", "effects.video_codec=null"], "effects.video_codec: 4:2:0 needs an even width"),
    (["effects.video_codec.codec=hevc", "camera.width_px=48"], "x265 needs frames of 64 px"),
    (["effects.video_codec.preset=warp"], "effects.video_codec.preset"),
])
def test_impossible_codecs_are_refused_naming_the_field(overrides, field):
    with pytest.raises(SceneError, match=field):
        load_scene("paper-default", [*SMALL, *overrides])


def test_the_effect_and_render_container_share_their_defaults():
    from typing import get_args

    from rollsim.effects.video_codec import VideoCodec
    from rollsim.video.settings import DEFAULT_PRESET, DEFAULT_TUNE, PRESETS, TUNES, VideoSettings

    defaults = VideoCodec()
    assert defaults.preset == DEFAULT_PRESET == VideoSettings().preset
    assert defaults.tune == DEFAULT_TUNE == VideoSettings().tune
    assert get_args(VideoCodec.model_fields["preset"].annotation) == PRESETS
    assert get_args(VideoCodec.model_fields["tune"].annotation) == TUNES
    assert defaults.chroma == VideoSettings().chroma and defaults.codec == VideoSettings().codec
    assert defaults.b_frames == VideoSettings().b_frames == 0


def test_chroma_given_on_the_command_line_reads_as_its_name():
    """--set effects.video_codec.chroma=444 is YAML's number 444: taken as the name '444'."""
    scene = load_scene("paper-default", [*SMALL, "effects.video_codec.chroma=444"])
    assert scene.effects.video_codec.chroma == "444"


def test_a_fit_with_a_vanishing_gain_still_makes_a_valid_scene():
    """Frames whose codec took the temporal noise away fit a gain near zero: the
    row and column patterns, in electrons, are held to the scene model's bound."""
    from rollsim.fit.camera import Parameters
    from rollsim.fit.fitted_scene import MAX_PATTERN_E, _effects
    from rollsim.scene import scene_from_dict

    p = Parameters(exposure_rows=3.0, smoothing_rows=0.0, gamma=1.0, on_lin=0.5, off_lin=0.01, k_lin=1e-12,
                   read_lin=1e-14, row_lin=1e-3, col_lin=1e-3)
    effects = _effects({}, p, 1.0, 0.0, None)
    assert effects["row_noise"]["std_e"] == effects["column_fpn"]["std_e"] == MAX_PATTERN_E
    scene_from_dict({"effects": effects}, "fitted")  # within the schema


@pytest.mark.parametrize("settings", [dict(bitrate_bps=2_000_000, gop_frames=12, chroma="444", codec="hevc"),
                                      dict(crf=0, preset="medium", chroma="gray")])
def test_settings_and_the_effects_parameters_map_both_ways(settings):
    from rollsim.effects.video_codec import VideoCodec, params_of, settings_of
    from rollsim.video.settings import VideoSettings

    given = VideoSettings(container="mkv", **settings)
    assert settings_of(VideoCodec(**params_of(given))) == given
