"""JPEG stills as a camera writes them: read wherever frames are read, and their EXIF exposure held by fit-camera.

A still's EXIF ExposureTime tells the exposure that the stripes tell only up
to whole periods and a reflection; stills of different exposures were not
taken with the settings locked, and are refused before any work.
"""

import json

import numpy as np
import pytest
from PIL import Image

from rollsim.cli import main
from rollsim.errors import RollsimError
from rollsim.fit.exif import StillSettings, exposure_how, locked_exposure_us, still_settings
from rollsim.render import render_frames
from rollsim.scene import load_scene
from rollsim.stages.decode import frame_files

# A 320x240 camera of 30 us rows, 300 us exposure, sRGB, at 2.5 kHz: 10 rows of exposure, a 26.7-row period.
HIDDEN = ["camera.width_px=320", "camera.height_px=240", "camera.row_time_us=30", "camera.exposure_us=300",
          "camera.iso=800", "led.size_mm=2.4", "led.position_px=[160,120]", "led.luminous_intensity_cd=0.0006",
          "link.pattern=square", "link.clock_hz=2500", "effects.tone_curve.curve=srgb", "camera.identity_seed=3"]


def _exif(exposure_s=None, iso=None, make=None, model=None) -> Image.Exif:
    exif = Image.Exif()
    if make:
        exif[0x010F] = make
    if model:
        exif[0x0110] = model
    tags = exif.get_ifd(0x8769)
    if exposure_s is not None:
        tags[0x829A] = exposure_s
    if iso is not None:
        tags[0x8827] = iso
    return exif


def _write_stills(folder, frames, exposures_s, quality=95):
    folder.mkdir()
    for k, (frame, seconds) in enumerate(zip(frames, exposures_s)):
        exif = _exif(seconds, 800, "Acme", "Phone 7") if seconds is not None else Image.Exif()
        Image.fromarray(frame).save(folder / f"IMG_{k:04d}.jpg", quality=quality, exif=exif)
    return folder


@pytest.fixture(scope="module")
def frames():
    images, _ = render_frames(load_scene("paper-geometric", HIDDEN), 4)
    return [np.asarray(im) for im in images]


def test_a_stills_exif_gives_its_exposure_iso_and_camera(tmp_path):
    Image.fromarray(np.zeros((24, 32), np.uint8)).save(tmp_path / "a.jpg", exif=_exif(1 / 2000, 400, "Acme", "X1"))
    s = still_settings(tmp_path / "a.jpg")
    assert s.exposure_us == pytest.approx(500.0) and s.iso == 400 and s.camera == "Acme X1"
    assert exposure_how(500.0, [s]) == "held as the stills' EXIF ExposureTime gives it (1/2000 s; Acme X1; ISO 400)"
    Image.fromarray(np.zeros((24, 32), np.uint8)).save(tmp_path / "bare.jpg")
    Image.fromarray(np.zeros((24, 32), np.uint8)).save(tmp_path / "b.png")
    (tmp_path / "junk.jpg").write_bytes(b"\xff\xd8\xff\xe1\x00\x10Exif\x00\x00garbage")
    for name in ("bare.jpg", "b.png", "junk.jpg"):
        assert still_settings(tmp_path / name) == StillSettings(str(tmp_path / name), None, None, None)


def test_one_exposure_is_held_and_stills_that_disagree_are_named():
    a, b = StillSettings("a.jpg", 500.0, None, None), StillSettings("b.jpg", 500.2, None, None)
    assert locked_exposure_us([a, b]) == pytest.approx(500.2)  # within a rational's rounding
    assert locked_exposure_us([StillSettings("c.png", None, None, None)]) is None
    with pytest.raises(ValueError, match=r"different exposures \(a.jpg: 1/2000 s, d.jpg: 1/1000 s"):
        locked_exposure_us([a, StillSettings("d.jpg", 1000.0, None, None)])
    with pytest.raises(ValueError, match="e.jpg: no EXIF exposure time, where a.jpg records 1/2000 s"):
        locked_exposure_us([a, StillSettings("e.jpg", None, None, None)])


def test_a_folder_of_jpeg_stills_is_a_folder_of_frames_and_pngs_beside_them_are_refused(tmp_path, frames):
    folder = _write_stills(tmp_path / "stills", frames[:2], [None, None])
    assert [p.name for p in frame_files(folder)] == ["IMG_0000.jpg", "IMG_0001.jpg"]
    Image.fromarray(frames[2]).save(folder / "extra.png")
    with pytest.raises(RollsimError, match=r"holds both PNG and JPEG frames \(2 JPEG, 1 PNG\)"):
        frame_files(folder)


def test_fit_camera_holds_the_stills_exif_exposure(frames, tmp_path, capsys):
    folder = _write_stills(tmp_path / "stills", frames, [300e-6] * len(frames))
    assert main(["fit-camera", str(folder), "--clock-hz", "2500", "--iterations", "1",
                 "--out", str(tmp_path / "fit")]) == 0
    exposure = json.loads((tmp_path / "fit" / "fit.json").read_text())["estimates"]["exposure_us"]
    assert exposure["source"] == "given" and exposure["value"] == pytest.approx(300.0)
    assert exposure["how"].startswith("held as the stills' EXIF ExposureTime gives it (1/3333 s; Acme Phone 7")
    assert "EXIF ExposureTime" in capsys.readouterr().err
    # --exposure-us wins over the EXIF, and says so.
    assert main(["fit-camera", str(folder), "--clock-hz", "2500", "--iterations", "0", "--exposure-us", "330",
                 "--out", str(tmp_path / "told")]) == 0
    told = json.loads((tmp_path / "told" / "fit.json").read_text())["estimates"]["exposure_us"]
    assert told["value"] == pytest.approx(330.0) and told["how"] == "held as given"
    assert "--exposure-us 330 held; the stills' EXIF records 300 us" in capsys.readouterr().err


def test_stills_of_different_exposures_are_refused_at_once_and_nothing_is_written(frames, tmp_path, capsys):
    folder = _write_stills(tmp_path / "stills", frames, [1 / 2000, 1 / 2000, 1 / 1000, 1 / 2000])
    assert main(["fit-camera", str(folder), "--clock-hz", "2500", "--out", str(tmp_path / "fit")]) == 2
    err = capsys.readouterr().err.strip()
    # One line, and no progress line of the fit before it: refused from the headers, before any work.
    assert "\n" not in err and "different exposures" in err and "IMG_0002.jpg: 1/1000 s" in err
    assert not (tmp_path / "fit").exists()


def test_jpeg_stills_decode_and_give_the_row_time(frames, tmp_path, capsys):
    folder = _write_stills(tmp_path / "stills", frames, [None] * len(frames))
    assert main(["estimate-row-time", str(folder), "--clock-hz", "2500", "--json", str(tmp_path / "rt.json")]) == 0
    assert json.loads((tmp_path / "rt.json").read_text())["row_time_us"] == pytest.approx(30.0, rel=0.005)


def test_stills_whose_stripes_run_along_the_columns_are_turned_and_said_so(frames, tmp_path, capsys):
    # A phone that stored its portrait stills turned: the rolling shutter's rows are the image's columns.
    turned = [np.ascontiguousarray(np.rot90(f, k=1)) for f in frames]  # a quarter turn anticlockwise
    folder = _write_stills(tmp_path / "portrait", turned, [None] * len(turned))
    assert main(["estimate-row-time", str(folder), "--clock-hz", "2500", "--json", str(tmp_path / "rt.json")]) == 0
    assert json.loads((tmp_path / "rt.json").read_text())["row_time_us"] == pytest.approx(30.0, rel=0.005)
    assert "the stripes run along the columns: frames turned 90 degrees clockwise" in capsys.readouterr().err
    # Told the other way round, the rows are read upside down: the same period.
    assert main(["estimate-row-time", str(folder), "--clock-hz", "2500", "--rotate", "270", "--json",
                 str(tmp_path / "rt2.json"), "--force"]) == 0
    assert json.loads((tmp_path / "rt2.json").read_text())["row_time_us"] == pytest.approx(30.0, rel=0.005)
    assert "stripes run along" not in capsys.readouterr().err


def test_a_render_saved_as_jpeg_stills_decodes(tmp_path, capsys):
    # paper-default's frames as a camera app saves them: decoded from the JPEGs with the scene beside them.
    from rollsim.cli import main as cli

    assert cli(["render", "paper-default", "--frames", "3", "--out", str(tmp_path / "run")]) == 0
    stills = tmp_path / "stills"
    stills.mkdir()
    for k, png in enumerate(sorted((tmp_path / "run" / "frames").glob("*.png"))):
        Image.open(png).save(stills / f"IMG_{k:04d}.jpg", quality=95)
    assert cli(["decode", str(stills), "--scene", str(tmp_path / "run" / "scene.resolved.yaml")]) == 0
    records = [json.loads(line) for line in (stills / "decoded.jsonl").read_text().splitlines()]
    assert {r["frame"] for r in records} == {0, 1, 2}
    assert sum(r.get("check_ok", False) for r in records) > 0


def test_an_exif_exposure_longer_than_the_frame_period_is_refused_in_one_line(frames, tmp_path, capsys):
    folder = _write_stills(tmp_path / "stills", frames[:2], [0.1, 0.1])  # 1/10 s against 30 frames/s
    assert main(["fit-camera", str(folder), "--clock-hz", "2500", "--out", str(tmp_path / "fit")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "EXIF exposure time (100000 us): not shorter than the frame period" in err
    assert not (tmp_path / "fit").exists()
