"""``rollsim bench envelope``: where the decoder works, as maps against the genie-aided bound.

Each *map* varies one physical quantity of a bundled scene, everything else
fixed, and runs the sweep engine's ``envelope`` stage on every point
(:func:`rollsim.sweeps.stages.envelope_row`): the same frames are read by
rollsim's decoder and by the genie-aided reference receiver
(:mod:`rollsim.stages.genie`), and each one's ok fraction of the fully visible
PHY-SDUs comes with its 95 % Wilson interval. A map is a 1-D curve along its
axis (:data:`MAPS`):

``exposure``
    exposure over the chip duration, 0.1 … 4 (paper-default; ISO scaled as
    10000 × 100 µs / exposure, as an auto-exposure camera keeps the image's
    brightness);
``snr``
    the stripe SNR (ON–OFF gap of a row mean over its noise σ, dB, the
    stage's ``stripe_snr_db``), 0 … 33 dB, through the LED's intensity
    (paper-geometric: the footprint, hence the LED's rows, does not depend
    on the intensity, as paper-default's glare rows do);
``blur``
    a Gaussian lens PSF's σ, px (paper-default);
``defocus``
    the defocus blur circle's diameter, px, through the focus distance
    (paper-default, LED at 5 cm);
``rows_per_chip``
    chip duration over the row time, 1 … 20, through the clock at the
    paper's row time (paper-default; exposure held at 0.8 chips, ISO scaled
    as for ``exposure``);
``contrast``
    the LED's time-averaged level over the background's, through the
    ambient light, 650 lx … 166 klx (paper-geometric; ISO scaled as
    10000 × 650 lx / ambient, so the background keeps its output level);
``saturation``
    the brightest pixel's ON level in full wells, 0.5 … 10, through the
    LED's intensity (effect-blooming: ISO 100, blooming on, no
    anti-blooming drain);
``shake``
    a hand holding the phone (``motion``'s ``handheld`` mode): the tremor's
    rms angle, 0.0125 … 0.8°, with the drift at 6 times it and the roll's
    tremor and drift equal to the pan's and tilt's (the defaults'
    proportions), one curve per rows per chip (1, 2, 4.5, 8, as for
    ``rows_per_chip``), on paper-default with its glare;
``compression``
    a phone's video recording (``video_codec``: H.264, one-second GOP,
    4:2:0, x264 ``superfast``) at 0.5 … 50 Mb/s, one curve per rows per
    chip (1, 2, 4.5, 8), on paper-default.

A map with a *series* (``shake``, ``compression``) is a family of curves, one per value of
the series column; each curve has its own boundaries.

The 95 %-ok boundary of a curve (:func:`ok_regions`): the axis values at
which the ok fraction, linearly interpolated between adjacent points (in
log x on a log axis), crosses 0.95. The table gives, per receiver, the
stretches of the axis where it is at least 0.95.
"""

from __future__ import annotations

import functools
import json
import math
import shlex
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional, Sequence, cast

from rollsim.bench.common import machine, strict_floats
from rollsim.errors import OutputError, RollsimError
from rollsim.plumbing.text_tables import format_table, markdown_table

OK_LEVEL = 0.95
FRAMES = 16
QUICK_FRAMES = 2
# paper-default (nexus5 preset): chip 125 µs at 8 kHz, row time 27.78 µs (IFG 0.1 at 30 fps).
PAPER_CHIP_US = 125.0
PAPER_ROW_TIME_US = 1e6 / 30.0 * 0.9 / 1080
PAPER_ISO = 10000.0
PAPER_EXPOSURE_US = 100.0
PAPER_EXPOSURE_CHIPS = PAPER_EXPOSURE_US / PAPER_CHIP_US
PAPER_AMBIENT_LUX = 650.0
# paper-geometric's LED (cd) and its median stripe SNR (dB); effect-blooming's LED and its full wells.
GEOMETRIC_CD = 0.0314
GEOMETRIC_SNR_DB = 45.3
BLOOMING_CD = 5.0
BLOOMING_FULL_WELLS = 1.05


def _round(value: float) -> float:
    """Six significant digits: grid values that read well in cell ids and tables."""
    return float(f"{value:.6g}")


def auto_iso(exposure_us: float) -> float:
    """ISO that keeps paper-default's image brightness at ``exposure_us`` (µs): 10000 × 100 µs / exposure."""
    return _round(PAPER_ISO * PAPER_EXPOSURE_US / exposure_us)


def _exposure(ratios: Sequence[float]) -> dict:
    exposure_us = [_round(r * PAPER_CHIP_US) for r in ratios]
    return {"camera.exposure_us": exposure_us, "camera.iso": [auto_iso(e) for e in exposure_us]}


def _snr(targets_db: Sequence[float]) -> dict:
    return {"led.luminous_intensity_cd": [_round(GEOMETRIC_CD * 10 ** ((t - GEOMETRIC_SNR_DB) / 20)) for t in targets_db]}


def _rows_per_chip(rows: Sequence[float]) -> dict:
    clock_hz = [_round(1e6 / (r * PAPER_ROW_TIME_US)) for r in rows]
    exposure_us = [_round(PAPER_EXPOSURE_CHIPS * 1e6 / c) for c in clock_hz]
    return {"link.clock_hz": clock_hz, "camera.exposure_us": exposure_us, "camera.iso": [auto_iso(e) for e in exposure_us]}


def _contrast(ambient_lux: Sequence[float]) -> dict:
    return {"environment.ambient_lux": [float(a) for a in ambient_lux],
            "camera.iso": [_round(PAPER_ISO * PAPER_AMBIENT_LUX / a) for a in ambient_lux]}


# The hand's proportions (motion's handheld defaults): drift rms 6 × the tremor's, roll as pan and tilt.
DRIFT_PER_TREMOR = 6.0
SHAKE_ROWS_PER_CHIP = (1.0, 2.0, 4.5, 8.0)


def _with_rows_per_chip(rows: Sequence[float], values: Sequence, keys_of: Callable[[Any], dict]) -> dict:
    """Every (rows per chip, value) pair, rows per chip outermost: the rows-per-chip
    keys and ``keys_of(value)``'s, zipped."""
    per_rows = _rows_per_chip(rows)
    points: dict = {}
    for k in range(len(rows)):
        for value in values:
            for key, item in [*((key, column[k]) for key, column in per_rows.items()), *keys_of(value).items()]:
                points.setdefault(key, []).append(item)
    return points


def _hand(tremor: float) -> dict:
    """The hand's keys for a tremor: drift :data:`DRIFT_PER_TREMOR` times it, roll as pan and tilt."""
    drift = _round(DRIFT_PER_TREMOR * tremor)
    return {"effects.motion.mode": "handheld", "effects.motion.tremor_deg": tremor, "effects.motion.drift_deg": drift,
            "effects.motion.roll_tremor_deg": tremor, "effects.motion.roll_drift_deg": drift}


def _shake(tremor_deg: Sequence[float], rows: Sequence[float]) -> dict:
    """Every (rows per chip, tremor) pair: the rows-per-chip keys and the hand's, zipped."""
    return _with_rows_per_chip(rows, tremor_deg, _hand)


def _compression(bitrates_mbps: Sequence[float], rows: Sequence[float]) -> dict:
    """Every (rows per chip, bitrate) pair: the rows-per-chip keys and the codec's bitrate, zipped."""
    return _with_rows_per_chip(rows, bitrates_mbps, lambda mbps: {"effects.video_codec.bitrate_bps": _round(mbps * 1e6)})


def _saturation(full_wells: Sequence[float]) -> dict:
    return {"led.luminous_intensity_cd": [_round(BLOOMING_CD * w / BLOOMING_FULL_WELLS) for w in full_wells]}


@dataclass(frozen=True)
class EnvelopeMap:
    """One map: a scene, the keys varied together, and the column plotted as its axis.

    Attributes
    ----------
    name : str
    title : str
    scene : str
        Bundled scene the map starts from.
    points : callable
        ``points(quick)``: ``{key: [values]}`` of the keys varied together.
    x : str
        Column of the axis (a stage column, a swept key, or an extra column).
    x_label : str
    log_x : bool
    holds : str
        What the map varies and holds, in a sentence.
    series : str or None
        Column whose values split the map into curves (None: one curve).
    series_label : str
        How a curve is named by its series value (``"{:.3g} rows/chip"``).
    """

    name: str
    title: str
    scene: str
    points: Callable[[bool], dict]
    x: str
    x_label: str
    log_x: bool
    holds: str
    series: Optional[str] = None
    series_label: str = "{:g}"


MAPS = (
    EnvelopeMap(
        "exposure", "Exposure / chip duration", "paper-default",
        lambda quick: _exposure([0.5, 2.0] if quick else [0.1, 0.25, 0.5, 0.8, 1, 1.25, 1.5, 2, 2.5, 3, 3.5, 4]),
        "exposure_chips", "exposure / chip duration", False,
        "paper-default; exposure 12.5 … 500 µs at 8 kHz, ISO 10000 × 100 µs / exposure (auto-exposure brightness)"),
    EnvelopeMap(
        "snr", "Stripe SNR", "paper-geometric",
        lambda quick: _snr([6.0, 30.0] if quick else [0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 33]),
        "stripe_snr_db", "stripe SNR of a row mean, dB (median over the LED's rows)", False,
        "paper-geometric (no glare: the LED's rows do not depend on its intensity); LED intensity scaled down"),
    EnvelopeMap(
        "blur", "Lens blur", "paper-default",
        lambda quick: {"effects.blur.sigma_px": [1.0, 16.0] if quick else [0.5, 1, 2, 4, 8, 16, 32, 64]},
        "effects.blur.sigma_px", "Gaussian PSF σ, px", True,
        "paper-default with a Gaussian lens PSF"),
    EnvelopeMap(
        "defocus", "Defocus", "paper-default",
        lambda quick: {"effects.defocus.focus_distance_cm": [5.5, 10.0] if quick
                       else [5.05, 5.1, 5.25, 5.5, 6, 7, 10, 20, 100]},
        "defocus_diameter_px", "defocus blur circle diameter, px", True,
        "paper-default (LED at 5 cm) with the lens focused at 5.05 … 100 cm"),
    EnvelopeMap(
        "rows_per_chip", "Rows per chip", "paper-default",
        lambda quick: _rows_per_chip([2.0, 8.0] if quick else [1, 1.5, 2, 3, 4.5, 6, 8, 10, 12, 15, 20]),
        "rows_per_chip", "rows per chip (chip duration / row time)", True,
        "paper-default; clock 1.8 … 36 kHz at the paper's 27.8 µs row time, exposure 0.8 chips, ISO scaled"),
    EnvelopeMap(
        "contrast", "LED against the background", "paper-geometric",
        lambda quick: _contrast([650.0, 20800.0] if quick else [650.0 * 2**k for k in range(9)]),
        "led_to_background", "LED mean level / background level", True,
        "paper-geometric; ambient 650 lx … 166 klx, ISO 10000 × 650 lx / ambient (background at a fixed output level)"),
    EnvelopeMap(
        "saturation", "Saturation with blooming", "effect-blooming",
        lambda quick: _saturation([0.5, 3.0] if quick else [0.5, 0.75, 1, 1.25, 1.3, 1.35, 1.4, 1.45, 1.5, 2, 3, 4, 6, 8, 10]),
        "on_full_wells", "ON level of the brightest pixel, full wells", True,
        "effect-blooming (paper-geometric at ISO 100, blooming with no anti-blooming drain); LED intensity scaled"),
    EnvelopeMap(
        "shake", "Hand shake", "paper-default",
        lambda quick: _shake([0.05, 0.4] if quick else [0.0125, 0.025, 0.05, 0.1, 0.2, 0.4, 0.8],
                             [4.5] if quick else SHAKE_ROWS_PER_CHIP),
        "effects.motion.tremor_deg", "tremor, rms angle in pan, tilt and roll, degrees", True,
        "paper-default with its glare, held in the hand (motion: handheld): drift 6 × the tremor, roll as pan "
        "and tilt; one curve per rows per chip (clock at the paper's row time, exposure 0.8 chips, ISO scaled)",
        series="rows_per_chip", series_label="{:.3g} rows/chip"),
    EnvelopeMap(
        "compression", "A phone's video encoder", "paper-default",
        lambda quick: _compression([1.0, 20.0] if quick else [0.5, 1, 2, 5, 10, 20, 50],
                                   [4.5] if quick else SHAKE_ROWS_PER_CHIP),
        "effects.video_codec.bitrate_bps", "H.264 bitrate, bits/s", True,
        "paper-default recorded as video (video_codec: H.264, one-second GOP, 4:2:0, superfast) at 0.5 … 50 Mb/s; "
        "one curve per rows per chip (clock at the paper's row time, exposure 0.8 chips, ISO scaled)",
        series="rows_per_chip", series_label="{:.3g} rows/chip"),
)
MAP_NAMES = tuple(m.name for m in MAPS)


def maps_by_name(text: Optional[str]) -> list[EnvelopeMap]:
    """The maps ``NAME,...`` names (all when None), in :data:`MAPS` order."""
    if not text:
        return list(MAPS)
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in MAP_NAMES]
    if unknown or not names:
        raise RollsimError(f"--maps {text}: unknown map {', '.join(unknown) or '(none)'}; maps: {', '.join(MAP_NAMES)}")
    return [m for m in MAPS if m.name in names]


# ------------------------------------------------------------------ boundary


def _coordinate(x: float, log_x: bool) -> float:
    return math.log(x) if log_x else x


def _between(x0: float, x1: float, fraction: float, log_x: bool) -> float:
    if log_x:
        return math.exp(math.log(x0) + fraction * (math.log(x1) - math.log(x0)))
    return x0 + fraction * (x1 - x0)


def ok_regions(x: Sequence[float], y: Sequence[float], level: float = OK_LEVEL,
               log_x: bool = False) -> list[tuple[float, float]]:
    """Stretches of the axis where the interpolated ok fraction is at least ``level``.

    The curve is linear between adjacent points (in log x when ``log_x``);
    each stretch ends where it crosses ``level`` (the 95 %-ok boundary), or
    at the first or last point.

    Parameters
    ----------
    x : sequence of float
        Axis values (any order; sorted here). Positive when ``log_x``.
    y : sequence of float
        Ok fractions, 0 … 1.
    level : float
    log_x : bool

    Returns
    -------
    list of (float, float)
        ``(low, high)`` in axis units, ascending; empty when no point reaches
        ``level``.
    """
    points = sorted(zip(x, y))
    regions: list[tuple[float, float]] = []
    start: Optional[float] = None
    for k, (xk, yk) in enumerate(points):
        if k > 0:
            xp, yp = points[k - 1]
            if (yp >= level) != (yk >= level):
                cut = _between(xp, xk, (level - yp) / (yk - yp), log_x)
                if start is None:
                    start = cut
                else:
                    regions.append((start, cut))
                    start = None
        if k == 0 and yk >= level:
            start = xk
    if start is not None:
        regions.append((start, points[-1][0]))
    return regions


def format_regions(regions: list[tuple[float, float]], x_min: float, x_max: float) -> str:
    """``"0.1 … 0.93"``, ``"≥ 3.2"`` (to the grid's end), ``"none"``."""
    if not regions:
        return "none"
    parts = []
    for low, high in regions:
        at_low, at_high = math.isclose(low, x_min), math.isclose(high, x_max)
        if at_low and at_high:
            parts.append(f"whole grid ({x_min:.3g} … {x_max:.3g})")
        elif at_low:
            parts.append(f"≤ {high:.3g}")
        elif at_high:
            parts.append(f"≥ {low:.3g}")
        else:
            parts.append(f"{low:.3g} … {high:.3g}")
    return ", ".join(parts)


# ------------------------------------------------------------------ running


def _specs(maps: list[EnvelopeMap], frames: int, quick: bool, seed: Optional[int]) -> list:
    """Each map's resolved sweep (every cell validated before anything runs)."""
    from rollsim.sweeps import spec_from_arguments, validate_cells

    resolved = []
    for m in maps:
        spec = spec_from_arguments(m.scene, zipped=m.points(quick), stage="envelope",
                                   options={"frames": frames, "seed": seed})
        try:
            resolved.append(validate_cells(spec))
        except RollsimError as exc:
            raise RollsimError([f"map {m.name}: {line}" for line in exc.lines]) from None
    return resolved


def _extra_columns(m: EnvelopeMap, scene_name: str, values: dict) -> dict:
    """Axis columns a map computes itself (the defocus blur circle)."""
    if m.name != "defocus":
        return {}
    from rollsim.effects.defocus import defocus_diameter_px
    from rollsim.scene import load_scene

    scene = load_scene(scene_name, [f"{key}={value}" for key, value in values.items()])
    return {"defocus_diameter_px": defocus_diameter_px(scene, scene.effects.defocus)}


def run_maps(maps: list[EnvelopeMap], frames: int, quick: bool = False, client=None, seed: Optional[int] = None,
             progress: Optional[Callable[[str], None]] = None) -> dict:
    """Every map's cells on the Dask ``client``; ``{name: rows}`` in grid order.

    All maps' cells are submitted at once (one task per cell), so the
    cluster stays busy across maps.
    """
    from rollsim.sweeps import _error_rows
    from rollsim.sweeps.engine import run_tasks
    from rollsim.sweeps.stages import compute_cells
    from rollsim.sweeps.table import table_rows

    resolved = _specs(maps, frames, quick, seed)
    pending = []
    for m, r in zip(maps, resolved):
        payload = [[(c.index, c.id, c.seed(r.seed), r.cell_values(c))] for c in r.cells]
        tasks = run_tasks(client, compute_cells, payload, "envelope", r.base, r.source, list(r.spec.overrides),
                          r.spec.stage_options(), None)
        pending.append((m, r, tasks))
    results = {}
    for m, r, tasks in pending:
        rows: list[dict] = []
        for batch, result in tasks:
            # A task that failed as a whole (its worker died): its cell's error row.
            rows.extend(_error_rows(batch, result) if isinstance(result, BaseException) else cast(list, result))
        keys = r.spec.swept_keys()
        table = table_rows(rows, r.cells, "envelope", keys)
        for row, cell in zip(table, r.cells):
            row.update(_extra_columns(m, r.spec.scene, cell.values))
        results[m.name] = table
        if progress is not None:
            failed = sum(1 for row in table if row["status"] != "ok")
            progress(f"map {m.name}: {len(table)} cells, {failed} failed")
    return results


def map_columns(m: EnvelopeMap, rows: list[dict]) -> list[str]:
    """The CSV's columns: the cell, the swept keys, extra axis columns, the stage's, the sweep's."""
    from rollsim.sweeps.table import columns_of

    keys = list(m.points(False))
    columns = columns_of("envelope", keys)
    extra = [name for name in (rows[0] if rows else {}) if name not in columns]
    return columns[:1 + len(keys)] + extra + columns[1 + len(keys):]


def _curve(rows: list[dict], m: EnvelopeMap, prefix: str) -> tuple[list, list, list, list]:
    """x, ok fraction, interval ends of the cells that have a value (and a positive x on a log axis)."""
    out: tuple[list, list, list, list] = ([], [], [], [])
    for row in rows:
        x, y = row.get(m.x), row.get(f"{prefix}ok_fraction")
        if row.get("status") != "ok" or x is None or y is None or (m.log_x and x <= 0):
            continue
        for target, value in zip(out, (x, y, row[f"{prefix}ok_ci_low"], row[f"{prefix}ok_ci_high"])):
            target.append(float(value))
    return out


RECEIVERS = (("", "rollsim decoder", "tab:blue"), ("genie_", "genie-aided receiver", "tab:orange"))


def curves_of(m: EnvelopeMap, rows: list[dict]) -> list[tuple[Optional[float], list[dict]]]:
    """The map's curves: ``[(series value, rows)]`` by rising value; one ``(None, rows)`` without a series.

    A row whose series column has no value (a failed cell) joins no curve.
    """
    if m.series is None:
        return [(None, rows)]
    values = sorted({float(r[m.series]) for r in rows if r.get(m.series) is not None})
    return [(v, [r for r in rows if r.get(m.series) is not None and math.isclose(float(r[m.series]), v)])
            for v in values]


def boundaries(m: EnvelopeMap, rows: list[dict]) -> list[dict]:
    """Each curve's stretches of the axis with ok ≥ 95 % per receiver, and the grid's span.

    One entry per curve; a series map's entries name their ``series`` column
    and ``series_value``, and count their ``cells`` and ``failed`` cells.
    """
    entries = []
    for value, curve_rows in curves_of(m, rows):
        result: dict = {"map": m.name, "x": m.x, "x_label": m.x_label}
        if m.series is not None:
            result.update(series=m.series, series_value=value)
        spans = []
        for prefix, _label, _colour in RECEIVERS:
            x, y, _low, _high = _curve(curve_rows, m, prefix)
            name = prefix.rstrip("_") or "decoder"
            result[name] = [list(r) for r in ok_regions(x, y, OK_LEVEL, m.log_x)] if x else []
            spans += x
        result["x_min"], result["x_max"] = (min(spans), max(spans)) if spans else (None, None)
        result["cells"] = len(curve_rows)
        result["failed"] = sum(1 for row in curve_rows if row["status"] != "ok")
        entries.append(result)
    if m.series is not None:
        # Cells that failed before their series column was known belong to no curve: count them once.
        unplaced = [row for row in rows if row.get(m.series) is None]
        if unplaced and entries:
            entries[0]["failed"] += len(unplaced)
    return entries


def plot_map(m: EnvelopeMap, rows: list[dict], bounds: list[dict], target) -> None:
    """Ok % of both receivers against the map's axis, 95 % intervals as bands, the 95 %-ok boundaries dashed.

    A series map draws one colour per curve, the decoder solid and the genie
    dotted, without bands or boundaries (they would hide the curves).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.4))
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.12, top=0.84)
    ax = fig.subplots()
    if m.series is None:
        _plot_single(ax, m, rows, bounds[0])
    else:
        _plot_series(ax, m, rows)
    ax.axhline(100 * OK_LEVEL, color="grey", linestyle=":", linewidth=1)
    if m.log_x:
        ax.set_xscale("log")
    if m.series is not None:
        # The grid's own values as ticks: a log axis's minor labels would overlap.
        ticks = sorted({float(r[m.x]) for r in rows if r.get(m.x) is not None})
        ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
        ax.minorticks_off()
    ax.set(xlabel=m.x_label, ylabel="ok % of fully visible PHY-SDUs", ylim=(-3, 103))
    import textwrap

    ax.set_title(m.title + "\n" + textwrap.fill(m.holds, 95), fontsize=8)
    ax.grid(alpha=0.3)
    if m.series is None:
        ax.legend(loc="best", fontsize=8, title="dashed: 95 %-ok boundary", title_fontsize=7)
    else:
        ax.legend(loc="best", fontsize=6, ncol=2)
    fig.savefig(target, dpi=100, format="png", metadata={"Software": None})


def _plot_series(ax, m: EnvelopeMap, rows: list[dict]) -> None:
    """One colour per curve of a series map, each receiver's ok % in its own line style."""
    from matplotlib import colormaps

    palette = colormaps["viridis"]
    curves = curves_of(m, rows)
    for k, (value, curve_rows) in enumerate(curves):
        colour = palette(k / max(1, len(curves) - 1) * 0.9)
        for (prefix, label, _c), style in zip(RECEIVERS, ("o-", "s:")):
            x, y, _low, _high = _curve(curve_rows, m, prefix)
            order = sorted(range(len(x)), key=x.__getitem__)
            ax.plot([x[i] for i in order], [100 * y[i] for i in order], style, color=colour, markersize=3,
                    label=f"{m.series_label.format(value)}, {label}")


def _plot_single(ax, m: EnvelopeMap, rows: list[dict], bounds: dict) -> None:
    """One curve per receiver with its interval band and its 95 %-ok boundaries."""
    for prefix, label, colour in RECEIVERS:
        x, y, low, high = _curve(rows, m, prefix)
        if not x:
            continue
        order = sorted(range(len(x)), key=x.__getitem__)
        xs = [x[i] for i in order]
        ax.fill_between(xs, [100 * low[i] for i in order], [100 * high[i] for i in order], color=colour, alpha=0.2,
                        linewidth=0)
        ax.plot(xs, [100 * y[i] for i in order], "o-", color=colour, markersize=3, label=label)
        for region in bounds[prefix.rstrip("_") or "decoder"]:
            for edge in region:
                if not (math.isclose(edge, xs[0]) or math.isclose(edge, xs[-1])):
                    ax.axvline(edge, color=colour, linestyle="--", linewidth=1)


# ------------------------------------------------------------------ output


def output_names(maps: list[EnvelopeMap]) -> list[str]:
    return [f"{m.name}.{ext}" for m in maps for ext in ("csv", "png")] + ["envelope.md", "envelope.json"]


def output_paths(out_dir: Path, maps: list[EnvelopeMap], force: bool) -> dict[str, Path]:
    """The output files in ``out_dir``; refuses existing ones without ``force`` (before any work)."""
    from rollsim.plumbing.outputs import check_file_targets

    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise OutputError(f"{out_dir}: exists and is not a directory")
    if not out_dir.exists() and not out_dir.resolve().parent.is_dir():
        raise OutputError(f"{out_dir}: parent directory {out_dir.resolve().parent} does not exist")
    paths = {name: out_dir / name for name in output_names(maps)}
    if out_dir.exists():
        check_file_targets(paths.values(), force)
    return paths


TABLE_HEADER = ("map", "axis", "grid", "decoder ok ≥ 95 %", "genie ok ≥ 95 %", "cells failed")


def table_rows(result: dict) -> list[tuple]:
    """One row per curve: a series map's curves are named by their series value."""
    labels = {m.name: m.series_label for m in MAPS}
    rows = []
    for b in result["boundaries"]:
        grid = "n/a" if b["x_min"] is None else f"{b['x_min']:.3g} … {b['x_max']:.3g}"
        regions = [format_regions([tuple(r) for r in b[name]], b["x_min"], b["x_max"]) if b["x_min"] is not None
                   else "n/a" for name in ("decoder", "genie")]
        name = b["map"]
        if b.get("series_value") is not None:
            name = f"{name} ({labels.get(name, '{:g}').format(b['series_value'])})"
        rows.append((name, b["x_label"], grid, *regions, b["failed"]))
    return rows


def format_markdown(result: dict) -> str:
    lines = [f"`{result['command']}` ({result['frames']} frames per cell, {result['seconds']:.0f} s on "
             f"{result['workers']} workers)", ""]
    return "\n".join(lines + markdown_table(table_rows(result), TABLE_HEADER))


def write_outputs(result: dict, maps: list[EnvelopeMap], paths: dict[str, Path], force: bool = False) -> None:
    """Each map's CSV and PNG, and the boundary table, committed together."""
    from rollsim.plumbing.outputs import figure_png, write_files
    from rollsim.sweeps.table import csv_text

    contents: dict = {paths["envelope.md"]: format_markdown(result) + "\n",
                      paths["envelope.json"]: json.dumps(result, indent=2, allow_nan=False) + "\n"}
    bounds: dict[str, list] = {}
    for b in result["boundaries"]:
        bounds.setdefault(b["map"], []).append(b)
    for m in maps:
        rows = result["maps"][m.name]
        contents[paths[f"{m.name}.csv"]] = csv_text(rows, map_columns(m, rows))
        contents[paths[f"{m.name}.png"]] = figure_png(functools.partial(plot_map, m, rows, bounds[m.name]))
    write_files(contents, force=force)


def command_line(args) -> str:
    """The command that reproduces a run (without --force)."""
    words = ["rollsim", "bench", "envelope", "--frames", str(args.frames)]
    if args.maps:
        words += ["--maps", args.maps]
    if args.quick:
        words.append("--quick")
    if args.seed is not None:
        words += ["--seed", str(args.seed)]
    if args.out:
        words += ["--out", args.out]
    return shlex.join(words)


def bench_envelope(maps: list[EnvelopeMap], frames: int, quick: bool = False, workers: Optional[int] = None,
                   scheduler: Optional[str] = None, seed: Optional[int] = None, progress=None) -> dict:
    """Run the maps on a Dask cluster (local, or ``scheduler``'s); a JSON-ready dict."""
    from rollsim.sweeps.engine import DaskEngine, worker_count

    start = time.perf_counter()
    with DaskEngine(workers, scheduler, "envelope").running() as client:
        results = run_maps(maps, frames, quick, client, seed, progress)
        n_workers = worker_count(client)
    return {"frames": frames, "quick": quick, "seconds": time.perf_counter() - start, "workers": n_workers,
            "machine": machine(), "ok_level": OK_LEVEL,
            "boundaries": [b for m in maps for b in boundaries(m, results[m.name])], "maps": results}


def main(args) -> int:
    maps = maps_by_name(args.maps)
    if args.frames is None:
        args.frames = QUICK_FRAMES if args.quick else FRAMES
    paths = output_paths(Path(args.out), maps, args.force) if args.out else None
    if args.json:
        from rollsim.plumbing.outputs import check_file_targets

        check_file_targets([args.json], args.force)
    progress = None if args.quiet else (lambda text: print(text, file=sys.stderr, flush=True))
    result = bench_envelope(maps, args.frames, args.quick, args.workers, args.scheduler, args.seed, progress)
    result = strict_floats({"command": command_line(args), **result})
    print(f"rollsim bench envelope: {args.frames} frames per cell, {result['seconds']:.0f} s")
    print(format_table(table_rows(result), TABLE_HEADER))
    if paths is not None:
        write_outputs(result, maps, paths, force=args.force)
        print(f"wrote {len(paths)} files to {args.out}")
    if args.json:
        from rollsim.plumbing.outputs import write_file

        write_file(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n", force=args.force)
    return 0
