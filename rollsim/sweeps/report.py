"""A sweep's report: ``report.md`` with a plot per figure.

One swept axis: a line per figure against it, with the 95 % interval as a
band where the stage gives one. Two axes: a heat map per figure. More:
small multiples, lines against the first axis coloured by the second, one
panel per combination of the others (at most :data:`MAX_PANELS`). Zipped
keys count as one axis, plotted against the first of them.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

MAX_PANELS = 12
# Fixed margins of the single-panel plots (fractions of the figure).
_MARGINS = {"left": 0.14, "right": 0.96, "bottom": 0.12, "top": 0.92}
# Figures plotted per stage, with the columns of their 95 % interval.
FIGURES: dict[str, list[tuple[str, tuple | None]]] = {
    "analytic": [("goodput_rp_bps", None), ("goodput_rs_bps", None), ("p_message_rp", None), ("p_message_rs", None),
                 ("M", None), ("N", None), ("roi_ratio", None)],
    "simulate": [("goodput_bps_mean", ("goodput_bps_ci_low", "goodput_bps_ci_high")),
                 ("duration_s_mean", ("duration_s_ci_low", "duration_s_ci_high")), ("completed_fraction", None)],
    "run": [("error_rate", None), ("p_e", ("p_e_ci_low", "p_e_ci_high")), ("M", None), ("N", None),
            ("goodput_replayed_bps", None), ("goodput_predicted_bps", None)],
    "envelope": [("ok_fraction", ("ok_ci_low", "ok_ci_high")), ("genie_ok_fraction", ("genie_ok_ci_low", "genie_ok_ci_high")),
                 ("stripe_snr_db", None)],
}


def _number(value) -> float:
    return math.nan if value is None or isinstance(value, (str, bool)) else float(value)


def _positions(values: list) -> tuple[list, list, bool]:
    """Distinct values of an axis in order, their plot positions, and whether they are numeric."""
    distinct = list(dict.fromkeys(values))
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in distinct)
    if numeric:
        distinct = sorted(distinct)
        return distinct, distinct, True
    return distinct, list(range(len(distinct))), False


def _line(ax, rows: list[dict], key: str, figure: str, band, label=None, colour=None):
    xs, positions, numeric = _positions([row[key] for row in rows])
    by_x = {row[key]: row for row in rows}
    y = [_number(by_x[x].get(figure)) for x in xs]
    line = ax.plot(positions, y, "o-", label=label, color=colour, markersize=3)[0]
    if band:
        low = [_number(by_x[x].get(band[0])) for x in xs]
        high = [_number(by_x[x].get(band[1])) for x in xs]
        ax.fill_between(positions, low, high, color=line.get_color(), alpha=0.2, linewidth=0)
    if not numeric:
        ax.set_xticks(positions, [str(x) for x in xs])
    return line


def plot_figure(rows: list[dict], axes_keys: Sequence[str], figure: str, band, stage: str, target) -> None:
    """One figure of the sweep against its axes, saved as PNG to ``target``."""
    from matplotlib.figure import Figure

    ok = [row for row in rows if row.get("status") == "ok"]
    if len(axes_keys) == 1:
        fig = Figure(figsize=(6.4, 4.0))
        fig.subplots_adjust(**_MARGINS)
        ax = fig.subplots()
        _line(ax, ok, axes_keys[0], figure, band)
        ax.set(xlabel=axes_keys[0], ylabel=figure, title=f"{figure} ({stage})")
        ax.grid(alpha=0.3)
    elif len(axes_keys) == 2:
        fig = _heat_map(ok, axes_keys, figure, stage)
    else:
        fig = _small_multiples(ok, axes_keys, figure, band, stage)
    fig.savefig(target, dpi=100, format="png", metadata={"Software": None})


def _heat_map(rows, axes_keys, figure, stage):
    import numpy as np
    from matplotlib.figure import Figure

    x_key, y_key = axes_keys
    xs, _, _ = _positions([row[x_key] for row in rows])
    ys, _, _ = _positions([row[y_key] for row in rows])
    grid = np.full((len(ys), len(xs)), np.nan)
    for row in rows:
        grid[ys.index(row[y_key]), xs.index(row[x_key])] = _number(row.get(figure))
    fig = Figure(figsize=(6.4, 4.8))
    fig.subplots_adjust(**_MARGINS)
    ax = fig.subplots()
    image = ax.imshow(np.ma.masked_invalid(grid), origin="lower", aspect="auto", interpolation="nearest")
    fig.colorbar(image, ax=ax, label=figure)
    step_x, step_y = max(1, len(xs) // 12), max(1, len(ys) // 12)
    ax.set_xticks(range(0, len(xs), step_x), [f"{x:g}" if isinstance(x, float) else str(x) for x in xs[::step_x]])
    ax.set_yticks(range(0, len(ys), step_y), [f"{y:g}" if isinstance(y, float) else str(y) for y in ys[::step_y]])
    ax.set(xlabel=x_key, ylabel=y_key, title=f"{figure} ({stage})")
    return fig


def _small_multiples(rows, axes_keys, figure, band, stage):
    from matplotlib.figure import Figure

    x_key, colour_key, panel_keys = axes_keys[0], axes_keys[1], list(axes_keys[2:])
    panels = list(dict.fromkeys(tuple(row[k] for k in panel_keys) for row in rows))[:MAX_PANELS]
    cols = min(4, len(panels))
    nrows = math.ceil(len(panels) / cols)
    # Constrained layout costs a tenth of a second a figure; only here, where
    # panel titles and labels would collide, is it worth it.
    fig = Figure(figsize=(3.6 * cols, 3.0 * nrows + 0.6), layout="constrained")
    axes = fig.subplots(nrows, cols, squeeze=False)
    colours = list(dict.fromkeys(row[colour_key] for row in rows))
    for ax, panel in zip(axes.ravel(), panels):
        members = [row for row in rows if tuple(row[k] for k in panel_keys) == panel]
        for index, value in enumerate(colours):
            subset = [row for row in members if row[colour_key] == value]
            if subset:
                _line(ax, subset, x_key, figure, band, label=f"{colour_key}={value}", colour=f"C{index % 10}")
        ax.set(title=", ".join(f"{k}={v}" for k, v in zip(panel_keys, panel)), xlabel=x_key, ylabel=figure)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"{figure} ({stage})")
    return fig


def plot_png(item: tuple) -> bytes:
    """PNG bytes of one figure: a task a worker can run.

    ``item`` is ``(figure, band, columns, axes_keys, stage)``, ``columns``
    holding only what the figure needs (``{name: values}`` of the cells
    that succeeded), so that it is cheap to send.
    """
    from rollsim.plumbing.outputs import figure_png

    figure, band, columns, axes_keys, stage = item
    rows = [dict(zip(columns, values), status="ok") for values in zip(*columns.values())]
    return figure_png(lambda target: plot_figure(rows, axes_keys, figure, band, stage, target))


def start_plots(rows: list[dict], axes_keys: Sequence[str], stage: str, submit=None) -> list[tuple]:
    """Start drawing every figure the stage has values for.

    Parameters
    ----------
    submit : callable, optional
        ``submit(plot_png, item)`` returning an object with ``result()``
        (a Dask client's ``submit``); by default each is drawn here, now.

    Returns
    -------
    list of (str, object)
        Each figure and its pending PNG, for :func:`report_files`.
    """
    ok = [row for row in rows if row.get("status") == "ok"]
    started = []
    for figure, band in FIGURES[stage]:
        if not any(row.get(figure) is not None for row in ok):
            continue
        names = [*dict.fromkeys([*axes_keys, figure, *(band or ())])]
        item = (figure, band, {name: [row.get(name) for row in ok] for name in names}, list(axes_keys), stage)
        started.append((figure, submit(plot_png, item) if submit is not None else _Done(plot_png(item))))
    return started


class _Done:
    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


def report_files(plots: list[tuple], rows: list[dict], axes_keys: Sequence[str], header_lines: Sequence[str],
                 directory: Path) -> dict:
    """``{path: bytes or text}`` of ``report.md`` and the plots of :func:`start_plots`, for one commit."""
    files, lines = {}, [*header_lines, "", "## Plots", ""]
    for figure, pending in plots:
        name = f"plots/{figure}.png"
        files[directory / name] = pending.result()
        lines += [f"### {figure}", "", f"![{figure}]({name})", ""]
    if len(axes_keys) > 3 or (len(axes_keys) == 3 and len({tuple(r[k] for k in axes_keys[2:]) for r in rows}) > MAX_PANELS):
        lines += [f"(Plots show the first {MAX_PANELS} combinations of {', '.join(axes_keys[2:])}; every cell is in "
                  "results.csv.)", ""]
    files[directory / "report.md"] = "\n".join(lines)
    return files
