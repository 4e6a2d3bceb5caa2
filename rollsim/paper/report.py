"""``paper.json``, ``report.md`` and the plots of ``rollsim paper``."""

from __future__ import annotations

import json
import math
from pathlib import Path

from rollsim.paper.experiments import DISTANCES_CM, ROI_MEASURED
from rollsim.plumbing.text_tables import format_number, markdown_table

READINGS = (
    "Fig. 14–17 use 'a 24 bits length PHY-SDU' with P = 19, H = 5: the length is P + H. Fig. 17's axis is read "
    "the same way, with just enough header bits for ceil(8G/P) packets.",
    "The 1 kB log is 422 packets of 19 bits: rollsim's mmbp channel and pixel pipeline use H = 9 to number them; "
    "the camcomsim channel keeps CamComSim's H = 5 (its sequence numbers wrap).",
    "Testbed numbers are compared with the pixel pipeline (deviation) and rollsim's mmbp channel; CamComSim's "
    "numbers with rollsim's camcomsim channel.",
    "The pixel ROI ratio is the mean fraction of rows in which the decoder reads the LED's stripes "
    "(decoder.stripe_row_fraction), whether or not a whole PHY-SDU fits in them.",
    "The pixel goodput is the scene's strategy replayed over the decoded outcome trace from 500 starts, the trace "
    "read cyclically (rollsim.calibrate.replay): a trace shorter than a few rounds reuses its own outcomes.",
)


def paper_document(result: dict) -> list:
    """The ``paper.json`` list: one comparison row per number (see :mod:`rollsim.paper.compare`)."""
    return [_json_safe(row) for row in result["rows"]]


def _json_safe(row: dict) -> dict:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()}


def _cell(value) -> str:
    if value is None:
        return "–"
    return format_number(value) if isinstance(value, float) else str(value)


def _pixel_cell(row: dict) -> str:
    """The pixel value; for p_e, with its interval or one-sided bound (never a bare 0)."""
    stated = [note for note in row["notes"] if note.startswith("p_e = ")]
    return stated[0] if row["quantity"] == "p_e" and stated else _cell(row["rollsim_pixel"])


def _deviation_cell(row: dict) -> str:
    if row["deviation"] is None:
        return "–"
    return f"{100 * row['deviation']:+.1f} % ({row['deviation_layer']})"


def figure_tables(rows: list) -> list[str]:
    """A markdown table per figure, in the order the rows come."""
    lines: list[str] = []
    figures = list(dict.fromkeys(row["figure"] for row in rows))
    header = ["quantity", "setting", "source", "paper", "analytic", "event", "pixel", "unit", "deviation"]
    for figure in figures:
        mine = [row for row in rows if row["figure"] == figure]
        table = [(row["quantity"], row["setting"], row["source"], _cell(row["paper"]), _cell(row["rollsim_analytic"]),
                  _cell(row["rollsim_event"]), _pixel_cell(row), row["unit"], _deviation_cell(row))
                 for row in mine]
        lines += [f"### {figure}", "", *markdown_table(table, tuple(header)), ""]
        notes = sorted({note for row in mine for note in row["notes"] if not note.startswith("p_e = ")})
        lines += [f"- {note}" for note in notes]
        if notes:
            lines.append("")
    return lines


def _distance_series(result: dict, layer: str, key: str) -> list:
    return [(result["figures"].get(f"d{d}", {}).get(layer) or {}).get(key) for d in DISTANCES_CM]


def _save_distance_plot(file, ylabel: str, title: str, draw, ylim=None) -> None:
    """A plot against distance: matplotlib's Figure directly (no pyplot state) and no
    software stamp in the PNG, as the run report's plots, so the same run gives the same file."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.5, 4.0), layout="constrained")
    ax = fig.subplots()
    draw(ax)
    ax.set(xlabel="distance (cm)", ylabel=ylabel, title=title)
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.savefig(file, format="png", dpi=110, metadata={"Software": None})


def _nan_for_none(values: list) -> list:
    return [math.nan if v is None else v for v in values]


def plot_roi(result: dict, file) -> None:
    """Fig. 11: the measured ROI ratio against rollsim's, by distance."""

    def draw(ax):
        ax.plot(DISTANCES_CM, list(ROI_MEASURED.values()), "o-", label="paper (testbed, Fig. 11)")
        ax.plot(DISTANCES_CM, _distance_series(result, "analytic", "roi_ratio"), "s--",
                label="rollsim analytic (LED rows)")
        ax.plot(DISTANCES_CM, _nan_for_none(_distance_series(result, "pixel", "roi_ratio")), "^-",
                label="rollsim pixel pipeline")

    _save_distance_plot(file, "ROI ratio", "ROI ratio against distance", draw, ylim=(0, 1.05))


def plot_goodput(result: dict, file) -> None:
    """Fig. 16: goodput and throughput against distance, every layer."""

    def draw(ax):
        for layer, style in {"analytic": "--", "event": ":", "pixel": "-", "camcomsim": "-."}.items():
            for key, colour in (("goodput_bps", "tab:green"), ("throughput_bps", "tab:red")):
                values = _nan_for_none(_distance_series(result, layer, key))
                if not all(math.isnan(v) for v in values):
                    ax.plot(DISTANCES_CM, values, style, color=colour, label=f"{key.split('_')[0]}, {layer}")
        ax.plot([10], [1000], "o", color="tab:green", label="goodput, testbed")
        ax.plot([10], [1940], "o", color="tab:red", label="throughput, testbed")

    _save_distance_plot(file, "bit/s", "Goodput and throughput against distance (G = 50 B, r = 1)", draw)


def report_text(document: list, result: dict, options, command: str) -> str:
    """``report.md``: how it was run, a table per figure, the plots, the readings of the text."""
    within = [row for row in document if row["deviation"] is not None and row["deviation_layer"] == "pixel"]
    close = sum(abs(row["deviation"]) <= 0.10 for row in within)
    lines = [
        "# rollsim against the paper", "",
        f"Made by `{command}` in {result['seconds']:.0f} s ({'quick' if options.quick else 'full'}: "
        f"{options.frames} frames per pixel setting, {options.runs} runs per event setting).", "",
        f"Pixel pipeline within 10 % of the paper: {close} of {len(within)} numbers that it gives.", "",
        "![ROI ratio](roi_distance.png)", "", "![goodput](goodput_distance.png)", "",
        "## Readings of the text", "", *[f"- {text}" for text in READINGS], "",
        "## Tables", "", *figure_tables(document),
    ]
    return "\n".join(lines) + "\n"


def write_report(directory: Path, document: list, result: dict, options, command: str) -> None:
    """Write ``paper.json``, ``report.md`` and the two plots into ``directory`` (a staging directory)."""
    from rollsim.plumbing.outputs import figure_png

    (directory / "paper.json").write_text(json.dumps(document, indent=1, allow_nan=False) + "\n")
    (directory / "roi_distance.png").write_bytes(figure_png(lambda f: plot_roi(result, f)))
    (directory / "goodput_distance.png").write_bytes(figure_png(lambda f: plot_goodput(result, f)))
    (directory / "report.md").write_text(report_text(document, result, options, command))
