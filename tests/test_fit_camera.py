"""rollsim fit-camera: its estimators against known answers, and the round trip
(frames rendered with hidden camera parameters, fitted, rendered again)."""

import json

import numpy as np
import pytest
import yaml

from rollsim.cli import main
from rollsim.fit.check import aligned_correlation
from rollsim.sensor.tone import srgb_encode
from rollsim.fit.measure import find_led_disk, temporal_noise
from rollsim.fit.noise import noise_gain, photon_transfer
from rollsim.fit.stripes import square_wave_box, stripe_profile
from rollsim.optics.footprint import footprint
from rollsim.scene import load_scene

# ------------------------------------------------------------ the stripe model


def test_a_short_box_is_the_square_wave_and_a_period_long_box_is_flat():
    rows = np.arange(0, 40, 0.25)
    square = ((rows + 3.0) % 10.0 < 5.0).astype(float)
    np.testing.assert_allclose(square_wave_box(rows + 1e-6, 10.0, 3.0, 1e-6), square, atol=1e-9)
    np.testing.assert_allclose(square_wave_box(rows, 10.0, 3.0, 10.0), 0.5, atol=1e-12)
    np.testing.assert_allclose(square_wave_box(rows, 10.0, 3.0, 20.0), 0.5, atol=1e-12)


def test_a_half_period_box_makes_a_triangle_wave():
    # Box of P/2 over a 50 % square wave: a triangle between 0 and 1 with slope 2/P.
    rows = np.arange(0, 20, 0.01)
    w = square_wave_box(rows, 8.0, 0.0, 4.0)
    assert w.min() == pytest.approx(0.0, abs=1e-12) and w.max() == pytest.approx(1.0, abs=1e-12)
    assert np.max(np.abs(np.diff(w) / 0.01)) == pytest.approx(2 / 8.0, rel=1e-6)
    assert w.mean() == pytest.approx(0.5, abs=2e-3)


def test_the_box_average_equals_the_sampled_integral():
    rows = np.linspace(0, 30, 301)
    fine = np.linspace(0, 1, 20001)
    period, phase, exposure = 7.3, 1.1, 2.9
    t = rows[:, None] + phase - exposure * fine[None, :]
    sampled = np.trapezoid(((t % period) < period / 2).astype(float), fine, axis=1)
    np.testing.assert_allclose(square_wave_box(rows, period, phase, exposure), sampled, atol=2e-4)


def test_stripe_profile_applies_the_tone_curve_to_the_linear_level():
    rows = np.arange(100)
    linear = stripe_profile(rows, 10.0, 0.0, 2.0, 0.0, 1.0, 0.8, 0.1)
    curved = stripe_profile(rows, 10.0, 0.0, 2.0, 0.0, 2.4, 0.8, 0.1)  # γ 2.4: sRGB
    np.testing.assert_allclose(curved, 255 * srgb_encode(linear / 255), atol=0.01)


# ------------------------------------------------------------------- measures


@pytest.mark.parametrize("centre, diameter", [((200.3, 150.7), 120.0), ((90.0, 60.2), 41.0), ((300.5, 20.0), 90.0)])
def test_the_disk_is_found_from_its_chords(centre, diameter):
    shape = (240, 400)
    fp = footprint(centre, diameter, "disk", shape, "exact")
    image = 40.0 + 180.0 * fp.dense(shape)
    disk = find_led_disk(image, 40.0)
    assert disk.centre_x_px == pytest.approx(centre[0], abs=0.6)
    assert disk.centre_y_px == pytest.approx(centre[1], abs=0.6)
    assert 2 * disk.radius_px == pytest.approx(diameter, rel=0.01)


def test_the_disk_needs_an_led():
    with pytest.raises(ValueError, match="no LED"):
        find_led_disk(np.full((50, 50), 30.0), 30.0)


def test_temporal_noise_separates_pixel_and_row_noise():
    rng = np.random.default_rng(4)
    fixed = rng.normal(0, 5, size=(200, 300))  # a fixed pattern: cancels in differences
    frames = [100 + fixed + rng.normal(0, 2.0, size=(200, 300)) + rng.normal(0, 0.7, size=(200, 1))
              for _ in range(6)]
    noise = temporal_noise(frames, slice(0, 200), slice(0, 300))
    assert noise.pixel_std == pytest.approx(2.0, rel=0.02)
    assert noise.row_std == pytest.approx(0.7, rel=0.1)


def test_photon_transfer_recovers_an_exact_line():
    u = np.linspace(0.05, 0.9, 40)
    a, b, a_sd, b_sd = photon_transfer(u, 1e-5 + 2e-3 * u)
    assert a == pytest.approx(1e-5, rel=1e-6) and b == pytest.approx(2e-3, rel=1e-6)


def test_noise_gain_is_the_kernels_sum_of_squares():
    assert noise_gain(0.0) == 1.0
    # A wide sampled Gaussian: Σk² → 1 / (2 σ √π).
    assert noise_gain(6.0) == pytest.approx(1 / (2 * 6.0 * np.sqrt(np.pi)), rel=1e-3)


def test_aligned_correlation_finds_the_phase():
    rows = np.arange(300)
    a = np.sin(2 * np.pi * rows / 12.0)
    b = np.sin(2 * np.pi * (rows + 3.3) / 12.0)
    assert aligned_correlation(a, b, 12.0) > 0.999
    assert aligned_correlation(a, np.random.default_rng(0).normal(size=300), 12.0) < 0.5


# ----------------------------------------------------------------- round trip

HIDDEN = {
    "camera.width_px": 480, "camera.height_px": 360, "camera.row_time_us": 31.7, "camera.exposure_us": 140,
    "camera.iso": 4000, "camera.read_noise_e": 3, "camera.identity_seed": 5,
    "led.size_mm": 2.4, "led.position_px": "[250.3,170.6]", "led.luminous_intensity_cd": 0.0012,
    "link.pattern": "square", "link.clock_hz": 4000,
    "effects.row_noise.std_e": 1, "effects.column_fpn.std_e": 1, "effects.tone_curve.curve": "srgb",
    "effects.isp_smoothing.sigma_rows_px": 1.2, "effects.sharpening.amount": 0.3, "effects.jpeg.quality": 90,
}


def _set(pairs: dict) -> list[str]:
    return [a for k, v in pairs.items() for a in ("--set", f"{k}={v}")]


@pytest.fixture(scope="module")
def round_trip(tmp_path_factory):
    root = tmp_path_factory.mktemp("fit")
    assert main(["render", "paper-geometric", "--out", str(root / "hidden"), "--frames", "6", "--quiet",
                 "--workers", "1", *_set(HIDDEN)]) == 0
    assert main(["fit-camera", str(root / "hidden" / "frames"), "--clock-hz", "4000", "--out", str(root / "fit")]) == 0
    return root


def test_fit_camera_recovers_the_hidden_camera(round_trip):
    hidden = load_scene("paper-geometric", [f"{k}={v}" for k, v in HIDDEN.items()])
    from rollsim.render import RenderPipeline

    setup = RenderPipeline(hidden).setup
    fit = json.loads((round_trip / "fit" / "fit.json").read_text())
    est = {k: v["value"] for k, v in fit["estimates"].items()}
    assert est["row_time_us"] == pytest.approx(31.7, rel=0.005)
    assert est["exposure_us"] == pytest.approx(140, rel=0.10)
    # Any other exposure the stripes allow is whole periods (500 us at 4 kHz) away, or the reflection.
    for alt in fit["estimates"]["exposure_us"].get("alternatives", []):
        k, r = (alt - est["exposure_us"]) / 500.0, (alt + est["exposure_us"]) / 500.0
        assert min(abs(k - round(k)), abs(r - round(r))) < 1e-6, alt
    assert est["led_centre_x_px"] == pytest.approx(250.3, abs=2)
    assert est["led_centre_y_px"] == pytest.approx(170.6, abs=2)
    assert est["led_diameter_px"] == pytest.approx(setup.led_size_px, rel=0.10)
    for name, pair in fit["check"]["noise_8bit"].items():
        if name.startswith("temporal"):
            assert pair["rendered"] == pytest.approx(pair["frames"], rel=0.15), name
    assert min(fit["check"]["row_profile_correlation"]) >= 0.98


def test_the_fitted_scene_renders_and_the_report_is_complete(round_trip, tmp_path):
    out = round_trip / "fit"
    assert {p.name for p in out.iterdir()} >= {"camera.yaml", "fit.json", "report.md", "profiles.png", "frames.png"}
    data = yaml.safe_load((out / "camera.yaml").read_text())
    assert data["link"]["pattern"] == "square" and data["camera"]["row_time_us"] > 0
    assert main(["render", str(out / "camera.yaml"), "--out", str(tmp_path / "again"), "--frames", "2",
                 "--quiet", "--workers", "1"]) == 0
    report = (out / "report.md").read_text()
    assert "Pearson correlation" in report and "temporal_background" in report and "](frames.png)" in report
    # Every parameter says where it came from; the lens and the distance never from frames.
    fit = json.loads((out / "fit.json").read_text())
    assert {e["source"] for e in fit["estimates"].values()} <= {"frames", "base scene", "not identified"}
    assert fit["estimates"]["focal_length_mm"]["source"] == "base scene"
    assert "| source |" in report and "| base scene |" in report
    import cv2

    picture = cv2.imread(str(out / "frames.png"), cv2.IMREAD_GRAYSCALE)
    assert picture is not None and picture.shape[1] > 2 * picture.shape[0] * 0.9  # two crops side by side
    # Outputs are never silently overwritten.
    assert main(["fit-camera", str(round_trip / "hidden" / "frames"), "--clock-hz", "4000", "--out", str(out),
                 "--iterations", "0"]) != 0


def test_fit_camera_refuses_bad_input_in_one_line(tmp_path, capsys):
    import cv2

    frames = tmp_path / "frames"
    frames.mkdir()
    for k in range(3):
        cv2.imwrite(str(frames / f"frame_{k:06d}.png"), np.full((60, 80), 40, np.uint8))
    assert main(["fit-camera", str(frames / "frame_000000.png"), "--clock-hz", "4000", "--out",
                 str(tmp_path / "a")]) != 0
    assert "at least two frames" in capsys.readouterr().err
    assert main(["fit-camera", str(frames), "--clock-hz", "4000", "--out", str(tmp_path / "b")]) != 0
    err = capsys.readouterr().err.strip()
    assert "square" in err and "\n" not in err
    assert main(["fit-camera", str(frames), "--clock-hz", "-1", "--out", str(tmp_path / "c")]) != 0
    assert "--clock-hz" in capsys.readouterr().err


@pytest.mark.parametrize("kind", ["mixed sizes", "all black", "1x1", "a JPEG named .png", "a text file"])
def test_bad_frames_leave_no_output_folder(tmp_path, capsys, kind):
    import cv2

    frames = tmp_path / "frames"
    frames.mkdir()
    for k in range(3):
        name = frames / f"frame_{k:06d}.png"
        if kind == "mixed sizes":
            cv2.imwrite(str(name), np.full((60 + 10 * k, 80), 40, np.uint8))
        elif kind == "all black":
            cv2.imwrite(str(name), np.zeros((60, 80), np.uint8))
        elif kind == "1x1":
            cv2.imwrite(str(name), np.full((1, 1), 40, np.uint8))
        elif kind == "a JPEG named .png":
            name.write_bytes(cv2.imencode(".jpg", np.full((60, 80), 40, np.uint8))[1].tobytes())
        else:
            name.write_text("not a frame\n")
    code = main(["fit-camera", str(frames), "--clock-hz", "4000", "--out", str(tmp_path / "out" / "cam")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frames"]
