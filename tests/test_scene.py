"""Scene files: validation, presets, layering and overrides."""

from pathlib import Path

import pytest
import yaml

from rollsim.errors import SceneError
from rollsim.scene import (
    PRESETS,
    bundled_scene_paths,
    load_scene,
    parse_overrides,
    scene_from_dict,
    scene_to_dict,
    scene_to_yaml,
)

BAD = sorted((Path(__file__).parent / "data" / "bad_scenes").glob("*.yaml"))


def test_every_bundled_scene_is_valid():
    paths = bundled_scene_paths()
    names = {p.stem for p in paths}
    assert {"paper-default", "paper-10cm"} <= names
    for path in paths:
        scene = load_scene(path)
        assert scene.name == path.stem
        assert scene.description


def test_one_bundled_scene_per_camera_preset():
    presets = {load_scene(p).camera.preset for p in bundled_scene_paths()}
    assert presets == set(PRESETS)


def test_paper_default_follows_the_paper():
    scene = load_scene("paper-default")
    cam, link = scene.camera, scene.link
    assert (cam.height_px, cam.frame_rate_hz, cam.exposure_us, cam.iso, cam.pixel_pitch_um) == (1080, 30, 100, 10000, 1.4)
    assert cam.ifg_ratio_effective == pytest.approx(0.1)
    assert (link.distance_cm, link.clock_hz, link.header_bits, link.payload_bits) == (5, 8000, 5, 19)
    assert (link.message_bytes, link.repeats, scene.channel.p_e) == (50, 1, 0.001)
    assert load_scene("paper-10cm").link.distance_cm == 10


def test_paper_handheld_is_paper_default_held_in_the_hand():
    """paper-handheld differs from paper-default in its motion (the handheld defaults) and its name only."""
    held, still = scene_to_dict(load_scene("paper-handheld")), scene_to_dict(load_scene("paper-default"))
    motion = held["effects"].pop("motion")
    assert motion["mode"] == "handheld"
    defaults = scene_to_dict(load_scene("paper-default", ["effects.motion.mode=handheld"]))["effects"]["motion"]
    assert motion == defaults
    for data in (held, still):
        data.pop("name"), data.pop("description")
    assert held == still


@pytest.mark.parametrize(
    "preset, row_time_us",
    [("galaxy_s3", 30.25), ("iphone4s", 24.12), ("iphone6s", 20.85), ("iphone3gs", 64.41)],
)
def test_presets_carry_published_line_delays(preset, row_time_us):
    scene = scene_from_dict({"camera": {"preset": preset}})
    assert scene.camera.row_time_s == pytest.approx(row_time_us * 1e-6)
    assert scene.camera.readout_s < scene.camera.frame_period_s


def test_every_preset_value_has_a_source():
    for preset in PRESETS.values():
        assert all(source.strip() for source in preset.sources().values())
        scene_from_dict({"camera": {"preset": preset.name}})  # each preset is valid


def test_row_time_follows_from_ifg_ratio():
    cam = load_scene("paper-default").camera
    assert cam.row_time_s == pytest.approx((1 / 30) * 0.9 / 1080)


def test_override_layers_preset_file_set():
    scene = load_scene("paper-default", ["camera.exposure_us=50", "link.distance_cm=10"])
    assert scene.camera.exposure_us == 50 and scene.link.distance_cm == 10
    assert scene.camera.iso == 10000  # from the preset, untouched


def test_row_timing_from_a_more_specific_layer_replaces_the_other():
    # The preset gives ifg_ratio; the file gives row_time_us: no conflict.
    scene = scene_from_dict({"camera": {"preset": "nexus5", "row_time_us": 20.0}})
    assert scene.camera.ifg_ratio is None and scene.camera.row_time_us == 20.0
    # The file gives row_time_us; --set gives ifg_ratio: --set wins.
    scene = scene_from_dict({"camera": {"row_time_us": 20.0}}, overrides=["camera.ifg_ratio=0.2"])
    assert scene.camera.row_time_us is None and scene.camera.ifg_ratio == 0.2


def test_both_row_timings_in_one_override_layer_is_an_error():
    with pytest.raises(SceneError, match=r"--set: camera.row_time_us and camera.ifg_ratio are both given"):
        scene_from_dict({}, overrides=["camera.row_time_us=20", "camera.ifg_ratio=0.2"])


def test_overrides_parse_yaml_values():
    assert parse_overrides(["a.b=1", "a.c=null", "d=[1, 2]", "e=text", "f=1e-3"]) == {
        "a": {"b": 1, "c": None},
        "d": [1, 2],
        "e": "text",
        "f": 1e-3,
    }
    with pytest.raises(SceneError, match="expected KEY=VALUE"):
        parse_overrides(["camera.exposure_us"])


def test_effects_can_be_listed_added_and_removed():
    scene = load_scene("paper-default", ["effects.read_noise=false", "effects.dsnu=null", "effects.shot_noise.method=gaussian"])
    assert scene.effects.enabled() == ("ambient", "shot_noise", "dsnu", "glare")
    assert scene.effects.shot_noise.method == "gaussian"
    assert scene_from_dict({"effects": ["prnu", "tone_curve"]}).effects.enabled() == ("prnu", "tone_curve")
    assert scene_from_dict({}).effects.enabled() == ()


def test_resolved_scene_round_trips():
    scene = load_scene("paper-default", ["camera.row_time_us=25"])
    again = scene_from_dict(yaml.safe_load(scene_to_yaml(scene)))
    assert again == scene
    assert scene_to_dict(again)["camera"]["row_time_us"] == 25


def test_several_errors_give_one_line_each():
    with pytest.raises(SceneError) as info:
        scene_from_dict({"frames": 0, "camera": {"iso": -1}, "led": {"colour": "red"}}, source="s.yaml")
    lines = info.value.lines
    assert len(lines) == 3 and all(line.startswith("s.yaml: ") for line in lines)
    assert any("led.colour: unknown key" in line for line in lines)


def test_missing_camera_keys_without_a_preset_are_named():
    with pytest.raises(SceneError, match=r"camera.width_px: required key is missing"):
        scene_from_dict({"camera": {"preset": None}})


def test_channel_needs_both_m_and_n():
    with pytest.raises(SceneError, match="give both M and N"):
        scene_from_dict({"channel": {"M": 5}})
    assert scene_from_dict({"channel": {"M": 5, "N": 2}}).channel.N == 2


def test_exposure_longer_than_frame_is_an_error_equal_is_fine():
    scene_from_dict({"camera": {"exposure_us": 1e6 / 30}})
    with pytest.raises(SceneError, match="longer than the frame period"):
        scene_from_dict({"camera": {"exposure_us": 40000}})


def test_missing_file_is_named():
    with pytest.raises(SceneError, match=r"nope.yaml: does not exist, as a file or a bundled scene"):
        load_scene("nope.yaml")


@pytest.mark.parametrize("path", BAD, ids=lambda p: p.stem)
def test_malformed_scene_gives_its_expected_error(path):
    expected = path.read_text().splitlines()[0].removeprefix("# expect: ").replace("{path}", str(path))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.lines == [expected]


def test_there_are_at_least_ten_malformed_scenes():
    assert len(BAD) >= 10


def test_the_scene_reference_documents_every_scene_key():
    from rollsim.scene import Camera, Channel, Effects, Environment, Led, Link, Render, Scene

    readme = (Path(__file__).parents[1] / "docs" / "scenes.md").read_text()
    for model in (Scene, Camera, Led, Link, Environment, Channel, Render, Effects):
        for key in model.model_fields:
            assert f"`{key}`" in readme or f"`{key}," in readme or f", `{key}`" in readme, f"{model.__name__}.{key}"
