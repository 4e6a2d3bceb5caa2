"""rollsim bench accuracy: fidelity settings against their reference, on a small scene."""

import csv
import io
import json
import math

import numpy as np
import pytest

from rollsim.bench.accuracy import (
    ACCURACY_COLUMNS,
    COST_COLUMNS,
    OUTPUT_FILES,
    accuracy_rows,
    bench_accuracy,
    effect_cost,
    format_accuracy,
    full_colour_image,
    outcome_agreement_pct,
    ssim_frame_indices,
    to_csv,
)
from rollsim.bench.image_error import ImageError
from rollsim.bench.variants import (
    KNOB_NAMES,
    NOISE_EFFECTS,
    effect_pair,
    flat_field_levels_e,
    flat_field_overrides,
    knob_by_name,
    knob_scenes,
)
from rollsim.cli import main
from rollsim.errors import RollsimError
from rollsim.render import RenderPipeline
from rollsim.scene import load_scene
from rollsim.sensor.cfa import cfa_channels

# paper-default shrunk to 320 x 400 px: an LED disk of ~380 px inside the
# frame (so it has edges), shorter PHY-SDUs so that some are fully visible.
TINY = [
    "camera.width_px=320", "camera.height_px=400", "camera.row_time_us=20", "led.size_mm=6.2",
    "led.luminous_intensity_cd=0.0035", "link.payload_bits=7", "link.message_bytes=10",
]
FRAMES = 6


def tiny_scene(*extra):
    # The geometric LED: the knobs' costs and errors, not the glare's.
    return load_scene("paper-geometric", TINY + list(extra))


@pytest.fixture(scope="module")
def result():
    knobs = [knob_by_name(name) for name in ("footprint_edge", "led_rise_time", "blur_kernel")]
    return bench_accuracy(tiny_scene(), FRAMES, knobs, effects=("blur",))


def _rows(result, knob):
    return {row["setting"]: row for k in result["knobs"] if k["knob"] == knob for row in k["settings"]}


def _strict_json(text):
    def refuse(name):
        raise ValueError(f"non-strict JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def test_reference_rows_are_exact_and_agree_fully(result):
    for knob in result["knobs"]:
        (reference,) = [row for row in knob["settings"] if row["reference"]]
        assert reference["setting"] == knob["reference"] == knob["settings"][0]["setting"]
        assert reference["rms_dn"] == 0 and reference["max_abs_dn"] == 0 and reference["rms_e"] == 0
        assert reference["identical"] and reference["psnr_db"] is None and reference["ssim"] == 1.0
        assert reference["agreement_pct"] == 100.0 and reference["time_vs_reference"] == 1.0
        assert reference["emissions"] > 0 and reference["p_e"] is not None and reference["M"] is not None
        assert reference["p_e_change"] == 0 and reference["M_change"] == 0


def test_edge_error_falls_with_supersampling(result):
    rows = _rows(result, "footprint_edge")
    errors = [rows[s]["rms_e"] for s in ("supersample1", "supersample4", "supersample16")]
    assert errors[0] > errors[1] > errors[2] > 0
    assert rows["supersample1"]["rms_dn"] > rows["supersample16"]["rms_dn"] > 0


def test_sampled_rise_time_error_falls_with_samples(result):
    rows = _rows(result, "led_rise_time")
    errors = [rows[f"sampled K={k}"]["rms_e"] for k in (1, 4, 16, 64)]
    assert errors == sorted(errors, reverse=True) and errors[-1] > 0
    assert rows["sampled K=1"]["rms_dn"] > rows["sampled K=16"]["rms_dn"]


def test_separable_blur_differs_from_full_by_rounding_only(result):
    separable = _rows(result, "blur_kernel")["separable"]
    assert separable["max_abs_dn"] <= 1
    assert separable["rms_e"] < 1e-9  # electrons: the ON level is ~30 e-


def test_effect_added_is_named(result):
    added = {k["knob"]: k["effect_added"] for k in result["knobs"]}
    assert added == {"footprint_edge": "", "led_rise_time": "led_rise_time", "blur_kernel": "blur"}


def test_csv_and_json_are_strict(result):
    text = to_csv(accuracy_rows(result), ACCURACY_COLUMNS)
    rows = list(csv.DictReader(io.StringIO(text)))
    assert tuple(rows[0]) == ACCURACY_COLUMNS
    assert len(rows) == sum(len(k["settings"]) for k in result["knobs"])
    assert not any(cell.lower() in ("nan", "inf", "-inf") for row in rows for cell in row.values())
    assert {row["identical"] for row in rows} <= {"true", "false", ""}
    _strict_json(json.dumps(result, allow_nan=False))
    cost = list(csv.DictReader(io.StringIO(to_csv(result["effects_cost"], COST_COLUMNS))))
    assert cost[0]["effect"] == "blur" and float(cost[0]["ms_with"]) > 0
    assert "inf" in format_accuracy(result)  # identical images: PSNR shown as inf in text only


def test_shot_noise_distance_is_largest_at_low_signal():
    # Without read noise, which hides part of the difference at a few electrons.
    scene = tiny_scene("effects.read_noise=false")
    result = bench_accuracy(scene, 2, [knob_by_name("shot_noise")], effects=())
    (knob,) = result["knobs"]
    rows = {row["setting"]: row for row in knob["settings"]}
    low, mid, high = rows["gaussian"]["ks_distance"]
    assert low > high and low > 3 * knob["flat_field"]["floor"][0]
    assert rows["poisson"]["ks_distance"] == [0.0, 0.0, 0.0]
    assert rows["gaussian"]["rms_dn"] is None  # the noiseless image does not depend on a noise method


def test_flat_field_is_flat_at_the_requested_level():
    scene = tiny_scene("effects.vignetting=null")
    scenes = knob_scenes(scene, knob_by_name("shot_noise"))
    level = flat_field_levels_e(scene)[0]
    reference = knob_by_name("shot_noise").settings[0]
    probe = RenderPipeline(scenes.scene(reference, noiseless=True, extra=flat_field_overrides(1000.0, 0.5)))
    e_per_lux = np.mean(probe.run_stages(0).electrons) / 1000.0
    state = RenderPipeline(scenes.scene(reference, noiseless=True, extra=flat_field_overrides(level / e_per_lux, 0.5))).run_stages(3)
    assert state.electrons.mean() == pytest.approx(level, rel=1e-9)
    centre = state.electrons[150:250, 110:210]
    assert np.ptp(centre) < 0.01 * level  # vignetting only, no LED


def test_flat_field_levels_span_a_few_electrons_to_near_saturation():
    scene = tiny_scene()
    low, mid, high = flat_field_levels_e(scene)
    cam = scene.camera
    adc_e = (2**cam.adc_bits - 1 - cam.black_level_dn) / cam.gain_dn_per_e_at_iso
    assert low == 2.0 and high == pytest.approx(0.75 * min(cam.full_well_e, adc_e))
    assert mid == pytest.approx(math.sqrt(low * high))


def test_full_colour_image_reassembles_a_known_image():
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, size=(5, 7, 3), dtype=np.uint8)
    mosaics = {}
    for pattern in ("RGGB", "BGGR", "GRBG", "GBRG"):
        channels = cfa_channels(pattern, rgb.shape[:2])
        mosaics[pattern] = np.take_along_axis(rgb, channels[..., None].astype(np.intp), axis=2)[..., 0]
    assert np.array_equal(full_colour_image(mosaics), rgb)
    with pytest.raises(ValueError):
        full_colour_image({"RGGB": mosaics["RGGB"]})


def test_demosaic_is_measured_against_the_full_colour_image():
    result = bench_accuracy(tiny_scene(), 2, [knob_by_name("demosaic")], effects=())
    (knob,) = result["knobs"]
    assert knob["compared_with"] == "full colour" and "camera.output: rgb8" in knob["effect_added"]
    errors = {row["setting"]: row["rms_dn"] for row in knob["settings"]}
    assert min(errors.values()) > 0  # no demosaicing recovers the full-colour image
    assert errors[knob["reference"]] == min(errors.values())


def test_outcome_agreement_matches_on_tx():
    ref = [{"tx": 1, "outcome": "ok"}, {"tx": 2, "outcome": "ok"}, {"tx": 3, "outcome": "missed"}]
    other = [{"tx": 1, "outcome": "ok"}, {"tx": 2, "outcome": "corrupted"}, {"tx": 4, "outcome": "ok"}]
    assert outcome_agreement_pct(ref, ref) == 100.0
    assert outcome_agreement_pct(ref, other) == 25.0  # tx 1 of {1, 2, 3, 4}
    assert outcome_agreement_pct([], []) is None


def test_image_error_known_answers():
    from skimage.metrics import peak_signal_noise_ratio

    from skimage.metrics import structural_similarity

    reference = np.zeros((8, 10), dtype=np.uint8)
    image = reference.copy()
    image[1, 2] = 10
    error = ImageError(255.0)
    error.add(reference, image, ssim=True)
    result = error.result()
    assert result["rms_dn"] == pytest.approx(math.sqrt(100 / 80)) and result["max_abs_dn"] == 10
    assert result["psnr_db"] == pytest.approx(peak_signal_noise_ratio(reference, image, data_range=255))
    assert result["ssim"] == pytest.approx(structural_similarity(reference, image, data_range=255))
    same = ImageError(255.0)
    same.add(reference, reference, ssim=True)
    assert same.result() == {"rms_dn": 0.0, "max_abs_dn": 0.0, "psnr_db": None, "identical": True, "ssim": 1.0,
                             "rms_e": None}


def test_ssim_frames_spread_over_the_run():
    assert ssim_frame_indices(30) == [0, 10, 19, 29]
    assert ssim_frame_indices(2) == [0, 1]


def test_knob_scenes_differ_only_by_the_setting():
    scene = tiny_scene()
    knob = knob_by_name("spectral_step")
    scenes = knob_scenes(scene, knob)
    peak = scenes.scene(knob.settings[-1])
    assert peak.effects.bayer.spectral_step_nm == "peak" and peak.camera.output == "rgb8"
    noiseless = scenes.scene(knob.settings[0], noiseless=True)
    assert not set(NOISE_EFFECTS) & set(noiseless.effects.enabled())
    assert set(noiseless.effects.enabled()) == {"ambient", "bayer"}
    assert set(KNOB_NAMES) == {"footprint_edge", "shot_noise", "read_noise", "blur_kernel", "blur_truncation",
                               "demosaic", "spectral_step", "led_rise_time"}


def test_effect_pairs_add_what_an_effect_needs():
    scene = tiny_scene()
    flicker = effect_pair(scene, "flicker")
    assert {"flicker", "ambient"} <= set(flicker.with_effect.effects.enabled())
    ambient = effect_pair(load_scene("effect-flicker"), "ambient")
    assert not {"ambient", "flicker"} & set(ambient.without_effect.effects.enabled())
    bayer = effect_pair(scene, "bayer")
    assert bayer.with_effect.camera.output == "rgb8" and bayer.without_effect.camera.output == "gray8"
    defocus = effect_pair(scene, "defocus")
    assert defocus.with_effect.effects.defocus.focus_distance_cm == pytest.approx(7.5)
    with pytest.raises(RollsimError, match="gray8"):
        effect_pair(load_scene("effect-bayer"), "tone_curve")
    listed = effect_pair(scene, "shot_noise")
    assert listed.listed and "shot_noise" not in listed.without_effect.effects.enabled()


def test_effect_cost_reports_an_effect_it_cannot_measure():
    row = effect_cost(load_scene("effect-bayer", ["camera.width_px=64", "camera.height_px=64"]), "tone_curve", 1)
    assert row["ms_added"] is None and "gray8" in row["note"]


def test_cli_writes_every_output_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "results"
    args = ["bench", "accuracy", "paper-default", "--frames", "2", "--knobs", "read_noise", "--effects", "blur", "dsnu",
            "--quiet", "--out", str(out)]
    for item in TINY:
        args += ["--set", item]
    assert main(args) == 0
    assert "read_noise" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == sorted(OUTPUT_FILES)
    result = _strict_json((out / "accuracy.json").read_text())
    assert result["command"].startswith("rollsim bench accuracy paper-default --frames 2 --set camera.width_px=320")
    assert result["machine"]["cpus"] >= 1 and [k["knob"] for k in result["knobs"]] == ["read_noise"]
    assert [c["effect"] for c in result["effects_cost"]] == ["blur", "dsnu"]
    png = (out / "accuracy_pareto.png").read_bytes()
    assert png.startswith(b"\x89PNG") and b"Software" not in png and b"matplotlib" not in png
    assert main(args) == 2
    assert "--force" in capsys.readouterr().err
    assert main(args + ["--force"]) == 0


def test_cli_names_an_unknown_knob_or_effect(capsys):
    assert main(["bench", "accuracy", "paper-default", "--knobs", "no_such_knob"]) == 2
    assert "footprint_edge" in capsys.readouterr().err
    assert main(["bench", "accuracy", "paper-default", "--effects", "no_such_effect"]) == 2
    assert "vignetting" in capsys.readouterr().err


def test_cli_effects_option_alone_measures_no_effect(tmp_path, capsys):
    args = ["bench", "accuracy", "paper-default", "--frames", "1", "--knobs", "blur_kernel", "--effects", "--quiet"]
    assert main(args + [f"--set={item}" for item in TINY] + ["--out", str(tmp_path)]) == 0
    assert "added by each effect" not in capsys.readouterr().out
    result = json.loads((tmp_path / "accuracy.json").read_text())
    assert result["effects_cost"] == [] and " --effects --out " in result["command"]


@pytest.mark.benchmark
def test_full_accuracy_run_on_paper_geometric(tmp_path):
    """The README's run: every knob and effect on paper-geometric at 1080p (a few minutes)."""
    out = tmp_path / "accuracy"
    assert main(["bench", "accuracy", "paper-geometric", "--out", str(out)]) == 0
    result = json.loads((out / "accuracy.json").read_text())
    assert [k["knob"] for k in result["knobs"]] == list(KNOB_NAMES)
    for knob in result["knobs"]:
        reference = next(row for row in knob["settings"] if row["reference"])
        assert reference["agreement_pct"] == 100.0
