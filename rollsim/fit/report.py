"""What ``rollsim fit-camera`` writes: the scene, the estimates and a report."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml

from rollsim.fit.check import Comparison
from rollsim.fit.refine import CameraFit

FILES = ("camera.yaml", "fit.json", "report.md", "profiles.png", "frames.png")


def scene_yaml(fit: CameraFit, sources: list[str]) -> str:
    """The fitted scene as a complete scene file (``rollsim render DIR/camera.yaml`` runs it)."""
    data = fit.scene.model_dump(mode="json", exclude_none=True)
    data["name"] = "fitted-camera"
    data["description"] = f"rollsim fit-camera of {len(sources)} frames"
    header = ("# Written by rollsim fit-camera: the base scene with the camera, ISP, LED\n"
              "# image and ambient light fitted to real frames (fit.json has each\n"
              "# estimate and its uncertainty; report.md compares the two).\n")
    return header + yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


def fit_json(fit: CameraFit, comparison: Comparison, clock_hz: float, sources: list[str]) -> str:
    payload = {
        "frames": sources,
        "clock_hz": clock_hz,
        "channel": fit.channel,
        "estimates": fit.to_json(),
        "notes": fit.notes,
        "check": {
            "row_profile_correlation": list(comparison.correlations),
            "noise_8bit": {k: {"frames": v[0], "rendered": v[1]} for k, v in comparison.noise.items()},
        },
    }
    return json.dumps(payload, indent=2, allow_nan=False) + "\n"


def profile_plot_png(comparison: Comparison, first_row: int) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rollsim.plumbing.outputs import figure_png

    real, sim = comparison.profile_pair
    rows = first_row + np.arange(real.size)
    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=100)
    ax.plot(rows, real, label="frames", lw=1.2)
    ax.plot(rows, sim, label="rendered from the fit", lw=1.0, alpha=0.8)
    ax.set_xlabel("row")
    ax.set_ylabel("8-bit level (LED's central columns)")
    ax.legend(loc="upper right")
    fig.tight_layout()
    data = figure_png(lambda f: fig.savefig(f, format="png", metadata={"Software": None}))  # type: ignore[arg-type]
    plt.close(fig)
    return data


def frames_png(comparison: Comparison) -> bytes:
    """The first frame and the first frame rendered from the fit, side by side, cropped at the LED."""
    import cv2

    real, sim = comparison.frame_pair
    gap = np.full((real.shape[0], max(4, real.shape[1] // 40)), 255, np.uint8)
    ok, data = cv2.imencode(".png", np.hstack([real, gap, sim]))
    if not ok:
        raise RuntimeError("could not encode frames.png")
    return data.tobytes()


def alternatives_lines(estimates: dict) -> list[str]:
    """A paragraph for each estimate the frames allow other values of (the exposure's whole stripe
    periods and reflection), so that a reader who knows the camera's setting can tell which is right."""
    lines = []
    for name, e in estimates.items():
        if e.alternatives:
            values = ", ".join(f"{v:.4g}" for v in e.alternatives)
            lines += ["", f"**{name}**: these frames allow {values} {e.unit} as well: where they do not clip, "
                      "frames rendered with any of these values are the same (whole stripe periods more, and "
                      "the reflection E ↔ P − E, with the LED's ON and OFF levels to match). The fit took the "
                      "one whose OFF level is nearest the ambient light on the LED's face; if the camera's "
                      "setting is known, it tells which is right (`fit-camera --exposure-us`)."]
    return lines


def report_md(fit: CameraFit, comparison: Comparison, sources: list[str]) -> str:
    lines = ["# rollsim fit-camera", "",
             f"{len(sources)} frames ({fit.channel}); the scene is `camera.yaml`, every estimate with its "
             "uncertainty and source in `fit.json`.",
             "", "## Estimates", "",
             "Source: `frames` (fitted to them), `base scene` (what frames of a square wave never show), "
             "`not identified` (what these frames do not show; the base scene's value is used, or the bound "
             "the reason gives) or `given` "
             "(told, and held: `--exposure-us`, `--tone`, `--binning-rows`).", "",
             "| quantity | value | ± 1σ | unit | source | how, or why not |", "|---|---|---|---|---|---|"]
    for name, e in fit.estimates.items():
        unc = "" if e.uncertainty is None or not np.isfinite(e.uncertainty) else f"{e.uncertainty:.4g}"
        why = e.how if e.reason is None else f"{e.how}; {e.reason}"
        lines.append(f"| {name} | {e.value:.6g} | {unc} | {e.unit} | {e.source} | {why} |")
    lines += alternatives_lines(fit.estimates)
    r = np.asarray(comparison.correlations)
    lines += ["", "## Frames against the fit", "",
              "![the first frame (left) and the first frame rendered from the fit (right), at the LED](frames.png)",
              "", "## Row profiles, frames against the fit", "",
              "![row profiles](profiles.png)", "",
              f"Pearson correlation of the row profiles (the LED's central columns, each rendered frame "
              f"shifted by its best phase within half a stripe period): mean {r.mean():.4f}, "
              f"lowest {r.min():.4f}, over {r.size} frame pairs.", "",
              "## Noise, 8-bit levels", "", "| figure | frames | rendered from the fit | difference |",
              "|---|---|---|---|"]
    for name, (ours, theirs) in comparison.noise.items():
        diff = f"{100 * (theirs / ours - 1):+.1f} %" if ours > 0 else ""
        lines.append(f"| {name} | {ours:.3f} | {theirs:.3f} | {diff} |")
    if "temporal_led_bright" in comparison.noise:
        lines += ["", "temporal_led_bright: the LED's rows that hold one level in two frames, clear of the clips; "
                  "the frames' brightest quarter, and the rendered rows at or above its least level."]
    if fit.notes:
        lines += ["", "## Notes", ""] + [f"- {n}" for n in fit.notes]
    lines += ["", "Not fitted: glare, sharpening and compression; their effect on the edges and the noise is "
              "absorbed by the fitted exposure, smoothing, tone curve and noise.", ""]
    return "\n".join(lines)


def fit_outputs(out: Path, fit: CameraFit, comparison: Comparison, clock_hz: float, sources: list[str]) -> dict:
    """``{path: text or bytes}`` of the five files."""
    contents = (scene_yaml(fit, sources), fit_json(fit, comparison, clock_hz, sources),
                report_md(fit, comparison, sources), profile_plot_png(comparison, fit.band[0].start),
                frames_png(comparison))
    return {out / name: data for name, data in zip(FILES, contents)}
