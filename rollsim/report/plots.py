"""The run report's plots, each a small function writing one PNG.

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot
state), and saved without a timestamp or software version so that the same
run gives the same files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

OUTCOME_COLOURS = {
    "ok": "#2ca02c",
    "undetected_error": "#9467bd",
    "corrupted": "#d62728",
    "missed": "#ff7f0e",
    "not_visible": "#bbbbbb",
}
MODEL_COLOURS = {"empirical": "#333333", "mmbp": "#1f77b4", "ge": "#ff7f0e", "position": "#2ca02c"}
MODEL_NAMES = {"mmbp": "MMBP", "ge": "Gilbert-Elliott", "position": "position model"}


def _figure(width_in: float, height_in: float, rows: int = 1, cols: int = 1):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=100, metadata={"Software": None})
    return path


# The sample frame's plot is 8 in wide at 100 dpi: about 750 pixels of axes.
SAMPLE_FRAME_WIDTH_PX = 800


def display_image(image: np.ndarray, max_width_px: int = SAMPLE_FRAME_WIDTH_PX) -> tuple[np.ndarray, int]:
    """``image`` reduced by block means to at most ``max_width_px`` columns, in its own dtype, and the factor k.

    A figure shows a 1080p frame on fewer pixels than it has: matplotlib's
    resampling of the whole frame at draw time cost about a second a plot;
    a block mean by the smallest integer factor k that fits is what the
    plot can show (the last rows and columns that do not fill a block are
    left out: the reduced image covers k times its own shape). k = 1
    returns ``image`` itself.
    """
    height, width = image.shape[:2]
    k = -(-width // max_width_px)
    if k <= 1:
        return image, 1
    h, w = height // k, width // k
    blocks = image[:h * k, :w * k].reshape(h, k, w, k, *image.shape[2:])
    reduced = blocks.mean(axis=(1, 3))
    shown = np.rint(reduced).astype(image.dtype) if np.issubdtype(image.dtype, np.integer) else reduced.astype(image.dtype)
    return shown, k


def plot_sample_frame(image: np.ndarray, views, frame: int, path: Path) -> Path:
    """The frame with each LED region (dashed) and each decoded PHY-SDU outlined.

    Parameters
    ----------
    image : ndarray
        The frame, gray or RGB.
    views : list of decoder.RegionView
        What the decoder saw (:func:`decoder.inspect_frame`).
    frame : int
    path : Path
    """
    from matplotlib.patches import Rectangle

    height, width = image.shape[:2]
    fig, axes = _figure(8.0, 8.0 * height / width + 0.6)
    ax = axes[0, 0]
    # Shown reduced to the plot's resolution, on the frame's own row and column coordinates (the
    # blocks it holds span k times its shape; a remainder of fewer than k rows or columns is left out).
    shown, k = display_image(image)
    ax.imshow(shown, cmap="gray" if image.ndim == 2 else None, interpolation="nearest",
              extent=(-0.5, k * shown.shape[1] - 0.5, k * shown.shape[0] - 0.5, -0.5))
    ax.set_xlim(-0.5, width - 0.5)
    ax.set_ylim(height - 0.5, -0.5)
    for view in views:
        cols = view.cols
        ax.add_patch(Rectangle((cols.start, view.rows.start), cols.stop - cols.start, view.rows.stop - view.rows.start,
                               fill=False, edgecolor="yellow", linestyle="--", linewidth=1.0))
        for sdu in view.sdus:
            colour = OUTCOME_COLOURS["ok"] if sdu.check_ok else OUTCOME_COLOURS["corrupted"]
            ax.add_patch(Rectangle((cols.start + 4, sdu.first_row_f), cols.stop - cols.start - 8, sdu.last_row_f - sdu.first_row_f,
                                   fill=False, edgecolor=colour, linewidth=1.6))
            label = f"seq {sdu.sequence}" if sdu.check_ok else sdu.status
            ax.text(cols.start + 12, sdu.first_row_f + 30, label, color=colour, fontsize=9, weight="bold")
    ax.set_title(f"frame {frame}: LED regions (dashed) and decoded PHY-SDUs (green ok, red failed)", fontsize=10)
    ax.set_xlabel("column (px)")
    ax.set_ylabel("row")
    return _save(fig, path)


def plot_row_profile(view, frame: int, path: Path) -> Path:
    """A region's row profile, the binarisation threshold and the decoded spans."""
    profile = view.profile
    rows = profile.first_row + np.arange(len(profile))
    fig, axes = _figure(10.0, 3.6)
    ax = axes[0, 0]
    ax.plot(rows, profile.values, color="#333333", linewidth=0.8, label="row mean over the region")
    if view.threshold is not None:
        ax.plot(rows, view.threshold, color="#d62728", linewidth=1.0, label="threshold (envelope midpoint)")
    for sdu in view.sdus:
        colour = OUTCOME_COLOURS["ok"] if sdu.check_ok else OUTCOME_COLOURS["corrupted"]
        ax.axvspan(sdu.first_row_f, sdu.last_row_f, color=colour, alpha=0.12)
    ax.set_xlabel("row")
    ax.set_ylabel("level (DN)")
    ax.set_title(f"frame {frame}: row profile; shaded: decoded PHY-SDUs", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    return _save(fig, path)


def capture_windows(truth: list[dict]) -> np.ndarray:
    """Per frame, [start, end] of the span its LED rows integrate (s); rows without LED are skipped."""
    spans = [
        (t["start_s"] + t["led_rows"][0] * t["row_time_s"], t["start_s"] + t["led_rows"][1] * t["row_time_s"] + t["exposure_s"])
        for t in truth
        if t.get("led_rows")
    ]
    return np.array(spans, dtype=np.float64).reshape(-1, 2)


def plot_outcome_timeline(outcomes: list[dict], truth: list[dict], path: Path, zoom_s: float = 0.25) -> Path:
    """Each emission's outcome against time: the whole run, and its start with the capture windows."""
    names = list(OUTCOME_COLOURS)
    start = np.array([o["start_s"] for o in outcomes])
    end = np.array([o["end_s"] for o in outcomes])
    kind = np.array([names.index(o["outcome"]) for o in outcomes], dtype=np.int64)
    fig, axes = _figure(10.0, 5.0, rows=2)
    whole, zoom = axes[0, 0], axes[1, 0]
    for index, name in enumerate(names):
        chosen = kind == index
        whole.scatter(start[chosen], np.full(chosen.sum(), index), s=6, color=OUTCOME_COLOURS[name], label=name)
    whole.set_yticks(range(len(names)), names, fontsize=8)
    whole.set_xlabel("emission start (s)")
    whole.set_title("outcome of every emitted PHY-SDU", fontsize=10)
    t0 = start.min() if start.size else 0.0
    for a, b in capture_windows(truth):
        if a < t0 + zoom_s:
            zoom.axvspan(a, b, ymin=0.7, ymax=0.95, color="#1f77b4", alpha=0.5)
    shown = start < t0 + zoom_s
    zoom.barh(np.zeros(shown.sum()), end[shown] - start[shown], left=start[shown], height=0.8,
              color=[OUTCOME_COLOURS[names[k]] for k in kind[shown]], edgecolor="white")
    zoom.set_yticks([0.0, 1.3], ["PHY-SDUs", "capture"], fontsize=8)
    zoom.set_ylim(-0.6, 1.9)
    zoom.set_xlim(t0, t0 + zoom_s)
    zoom.set_xlabel("time (s)")
    zoom.set_title(f"first {zoom_s:g} s: PHY-SDUs by outcome, and each frame's capture window (LED rows + exposure)", fontsize=10)
    return _save(fig, path)


def plot_run_lengths(calibration: dict, path: Path) -> Path:
    """Success-run and loss-run length distributions: empirical against each fitted model."""
    runs = calibration["run_lengths"]
    fig, axes = _figure(10.0, 3.6, cols=2)
    for ax, kind in zip(axes[0], ("success", "loss")):
        models = runs[kind]
        bins = len(models["empirical"])
        x = np.arange(1, bins + 1)
        for offset, name in zip((-0.27, 0.0, 0.27), ("empirical", "mmbp", "ge")):
            ax.bar(x + offset, models[name], width=0.27, color=MODEL_COLOURS[name], label=name.upper() if name != "empirical" else name)
        ax.set_xticks(x, [str(v) for v in x[:-1]] + [f"≥{bins}"], fontsize=8)
        ax.set_xlabel(f"{kind} run length (emissions)")
        ax.set_ylabel("fraction of runs")
        ax.set_title(f"{kind} runs", fontsize=10)
        ax.legend(fontsize=8)
    return _save(fig, path)


def plot_message_curves(calibration: dict, path: Path) -> Path:
    """P(whole message in one round) against r: fitted models against the trace."""
    curves = calibration["message"]["curves"]
    fig, axes = _figure(10.0, 3.6, cols=2)
    for ax, strategy in zip(axes[0], ("rp", "rs")):
        rows = [c for c in curves if c["strategy"] == strategy]
        r = [c["r"] for c in rows]
        ax.plot(r, [c["mmbp"] for c in rows], "-o", color=MODEL_COLOURS["mmbp"], label="MMBP fit", markersize=4)
        ax.plot(r, [c["ge"] for c in rows], "-s", color=MODEL_COLOURS["ge"], label="GE fit", markersize=4)
        empirical = [(c["r"], c["empirical"]) for c in rows if c["empirical"] is not None]
        if empirical:
            ax.plot(*zip(*empirical), "x", color=MODEL_COLOURS["empirical"], label="trace", markersize=8)
        ax.set_ylim(-0.03, 1.03)
        ax.set_xlabel("r (copies)")
        ax.set_ylabel("P(message)")
        ax.set_title(f"{strategy.upper()}, N_p = {calibration['message']['n_packets']}", fontsize=10)
        ax.legend(fontsize=8)
    return _save(fig, path)


def plot_goodput(calibration: dict, path: Path) -> Path:
    """Goodput for RP and RS, r = 1 … 6: each fitted model's prediction against the trace replayed (95 % interval)."""
    table = calibration.get("goodput") or []
    fig, axes = _figure(10.0, 3.6, cols=2)
    for ax, strategy in zip(axes[0], ("rp", "rs")):
        rows = [g for g in table if g["strategy"] == strategy]
        replayed = {g["r"]: g for g in rows}
        r = np.array(sorted(replayed))
        centre = np.array([replayed[k]["replayed_bps"] or 0.0 for k in r])
        spans = [replayed[k]["interval"] or [centre[i], centre[i]] for i, k in enumerate(r)]
        error = np.abs(np.array(spans).T - centre)
        ax.errorbar(r, centre, yerr=error, fmt="x", color=MODEL_COLOURS["empirical"], capsize=3, markersize=8,
                    label="trace replayed (95 %)")
        for model in dict.fromkeys(g["model"] for g in rows):
            points = sorted((g["r"], g["predicted_bps"]) for g in rows if g["model"] == model and g["predicted_bps"] is not None)
            if not points:
                continue
            ax.plot(*zip(*points), "-o", color=MODEL_COLOURS.get(model, "#777777"), markersize=4,
                    label=MODEL_NAMES.get(model, model))
        ax.set_xticks(r)
        ax.set_xlabel("r (copies)")
        ax.set_ylabel("goodput (bit/s)")
        ax.set_title(f"{strategy.upper()}: predicted against replayed", fontsize=10)
        ax.legend(fontsize=8)
    return _save(fig, path)


def _plain_log_axis(axis) -> None:
    """Log ticks at 1, 2, 5 × 10^k labelled as plain numbers."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.set_minor_formatter(NullFormatter())


def _pareto_panel(ax, knobs: list[dict], value, ylabel: str, title: str, floors=None) -> None:
    """Time per frame against ``value(row)`` for each setting of ``knobs``.

    Zero values sit on a dotted floor line, hollow; ``floors`` (one value or
    None per knob) draws a dashed line per knob, e.g. a statistic's noise floor.
    """
    from matplotlib import colormaps

    points = [(i, row, value(row)) for i, knob in enumerate(knobs) for row in knob["settings"]]
    points = [(i, row, y) for i, row, y in points if y is not None]
    if not points:
        ax.text(0.5, 0.5, "no knob of this kind measured", ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
        return
    positive = [y for _, _, y in points if y > 0] + [f for f in (floors or []) if f]
    zero_line = min(positive) / 10.0 if positive else 1e-3
    colours = colormaps["tab10"]
    for i, knob in enumerate(knobs):
        colour = colours(i % 10)
        for j, row, y in points:
            if j != i:
                continue
            on_floor = y <= 0
            y = zero_line if on_floor else y
            ax.scatter(row["ms_per_frame"], y, s=150 if row["reference"] else 40, marker="*" if row["reference"] else "o",
                       facecolors="none" if on_floor and not row["reference"] else colour,
                       edgecolors="black" if row["reference"] else colour, linewidths=1.0, zorder=3)
            ax.annotate(row["setting"], (row["ms_per_frame"], y), xytext=(4, 3), textcoords="offset points",
                        fontsize=7, color=colour)
        ax.scatter([], [], color=colour, s=40, label=knob["knob"])
        if floors and floors[i]:
            ax.axhline(floors[i], color=colour, linestyle="--", linewidth=0.8)
    ax.axhline(zero_line, color="#999999", linestyle=":", linewidth=0.8)
    ax.text(0.01, zero_line, " 0: same as the reference", transform=ax.get_yaxis_transform(), fontsize=7,
            va="bottom", color="#666666")
    ax.scatter([], [], marker="*", s=150, color="white", edgecolors="black", label="reference")
    if floors:
        ax.plot([], [], color="#666666", linestyle="--", linewidth=0.8, label="noise floor (another seed)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    _plain_log_axis(ax.xaxis)
    ax.set_xlabel("render time per frame (ms, one core)")
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, loc="best")
    ax.grid(True, which="both", alpha=0.3)


def _first(values):
    return values[0] if values else None


def plot_accuracy_pareto(knobs: list[dict], target):
    """What accuracy costs (``rollsim bench accuracy``): time against error, one marker per setting.

    Left, the knobs that change the noiseless image: RMS error in DN against
    the reference (demosaicing: against the full-colour image). Right, the
    noise methods: Kolmogorov-Smirnov distance of flat fields at the lowest
    signal, with the distance two seeds of the reference give. Colour per
    knob, the reference a star; settings with no error sit on the dotted line.

    Parameters
    ----------
    knobs : list of dict
        ``knobs`` of :func:`rollsim.bench.accuracy.bench_accuracy`.
    target : path or binary file
    """
    fig, axes = _figure(13.0, 5.5, cols=2)
    image = [k for k in knobs if not k["noise"]]
    noise = [k for k in knobs if k["noise"]]
    _pareto_panel(axes[0, 0], image, lambda row: row["rms_dn"], "RMS error of the noiseless image (DN)",
                  "image: error against the reference")
    _pareto_panel(axes[0, 1], noise, lambda row: _first(row["ks_distance"]),
                  "Kolmogorov-Smirnov distance, flat field at the lowest signal", "noise: distribution distance",
                  floors=[_first(k["flat_field"]["floor"]) for k in noise])
    return _save(fig, target)
