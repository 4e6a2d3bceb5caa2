"""``rollsim paper``: every experiment of the reference paper, through rollsim, in one command.

The paper's settings and numbers are in :mod:`rollsim.paper.experiments`;
rollsim's three layers in :mod:`rollsim.paper.layers`; the comparison rows
in :mod:`rollsim.paper.compare`; the report in :mod:`rollsim.paper.report`.
The pixel pipeline and the event simulator run on the sweep engine (a
local Dask cluster, or ``scheduler``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

__all__ = ["PaperOptions", "compute_comparisons", "run_paper"]


@dataclass(frozen=True)
class PaperOptions:
    """How much to run: frames per pixel setting, runs per event setting.

    ``quick`` runs a reduced set (the pixel pipeline on the distances and
    two payload lengths only).
    """

    quick: bool = False
    frames: int = 300
    runs: int = 1000

    @classmethod
    def make(cls, quick: bool = False, frames: Optional[int] = None, runs: Optional[int] = None) -> "PaperOptions":
        defaults = (60, 200) if quick else (300, 1000)
        return cls(quick, frames or defaults[0], runs or defaults[1])


def _one_round_fractions(M: int, N: int, p_e: float, n_packets: int, r_values, runs: int, seed: int) -> dict:
    """Simulated fraction of runs complete within their first round, per (strategy, r)."""
    from rollsim.channel.channels import MmbpChannel
    from rollsim.channel.eventsim import simulate_broadcast
    from rollsim.transmitter import Schedule

    channel = MmbpChannel(M, N, p_e, 0.007)
    out = {}
    for strategy in ("rp", "rs"):
        for r in r_values:
            result = simulate_broadcast(channel, Schedule(strategy, n_packets, r), header_bits=5, payload_bits=19,
                                        runs=runs, seed=seed, workers=1, max_emissions=r * n_packets)
            out[(strategy, r)] = float(result.completed.mean())
    return out


def _camcomsim_figures(overrides: tuple, runs: int) -> dict:
    from rollsim.channel.scene_channel import scene_relaxations
    from rollsim.paper.layers import event_figures, load

    return event_figures(load(overrides, scene_relaxations("camcomsim")), "camcomsim", runs)


def _mmbp_figures(overrides: tuple, runs: int) -> dict:
    from rollsim.paper.layers import event_figures, load

    return event_figures(load(overrides), "mmbp", runs)


def throughput_bound_text(pixel: dict) -> str:
    """The pixel's throughput beside the bound its own measured ROI sets (one report note)."""
    bound = pixel["throughput_bound_bps"]
    return (f"rollsim's pixel: {pixel['throughput_bps']:.0f} bit/s, {pixel['throughput_bps'] / bound:.0%} of the "
            f"{bound:.0f} bit/s that every whole PHY-SDU in its own measured ROI ({pixel['roi_ratio']:.3f}) gives: "
            "its throughput follows its ROI")


def compute_comparisons(options: PaperOptions, client, progress: Optional[Callable[[str], None]] = None) -> dict:
    """Every comparison row, computed on ``client`` (a ``dask.distributed.Client``).

    Returns
    -------
    dict
        ``rows`` (the comparison rows), ``figures`` (per setting and layer:
        the figures behind them, for the report's curves), ``seconds``.
    """
    from distributed import as_completed

    from rollsim.paper.compare import analytic_rows, comparison_row, layer_values, message_probability_rows
    from rollsim.paper.experiments import claims, settings
    from rollsim.paper.layers import analytic_figures, load, pixel_figures

    say = progress or (lambda text: None)
    start = time.perf_counter()
    all_settings = settings()
    wanted = {key for _, key in claims()}
    futures = {}
    for key in sorted(wanted):
        setting = all_settings[key]
        if setting.pixel and (setting.quick_pixel or not options.quick):
            frames = max(1, round(options.frames * setting.frames_factor))
            futures[client.submit(pixel_figures, setting.overrides, frames, pure=False)] = (key, "pixel")
    for key in sorted(wanted):
        setting = all_settings[key]
        futures[client.submit(_mmbp_figures, setting.overrides, options.runs, pure=False)] = (key, "event")
        if setting.camcomsim:
            overrides = (*setting.overrides, *setting.camcomsim_overrides)
            futures[client.submit(_camcomsim_figures, overrides, options.runs, pure=False)] = (key, "camcomsim")
    r_values = range(1, 7)
    one_round = client.submit(_one_round_fractions, 3, 2, 0.001, 22, r_values, options.runs, 1, pure=False)
    figures = {key: {"analytic": analytic_figures(load(all_settings[key].overrides))} for key in wanted}
    say(f"{len(futures)} settings on the cluster")
    for done, future in enumerate(as_completed(list(futures), loop=client.loop), 1):
        key, layer = futures[future]
        figures[key][layer] = future.result()
        say(f"[{done}/{len(futures)}] {key} {layer}")
    rows = analytic_rows()
    rows += message_probability_rows(3, 2, 0.001, 22, r_values, one_round.result())
    for claim, key in claims():
        pixel = figures[key].get("pixel") or {}
        notes = [pixel["p_e_text"]] if claim.quantity == "p_e" and pixel.get("p_e_text") else []
        if claim.quantity == "throughput" and claim.paper is not None and pixel.get("throughput_bound_bps"):
            notes.append(throughput_bound_text(pixel))
        rows.append(comparison_row(claim, layer_values(claim, figures[key]), notes))
    return {"rows": rows, "figures": figures, "seconds": time.perf_counter() - start}


def run_paper(out: Path, options: PaperOptions, *, workers: Optional[int] = None, scheduler: Optional[str] = None,
              force: bool = False, command: str = "", progress: Optional[Callable[[str], None]] = None) -> list:
    """Run every comparison and write ``out/paper.json``, ``out/report.md`` and the plots, atomically.

    Returns
    -------
    list of dict
        The ``paper.json`` document: one row per comparison.
    """
    from rollsim.plumbing.outputs import staged_directory
    from rollsim.paper.report import paper_document, write_report
    from rollsim.sweeps.engine import DaskEngine

    with staged_directory(out, force=force) as staging:
        with DaskEngine(workers=workers, scheduler=scheduler, stage="run").running() as client:
            result = compute_comparisons(options, client, progress)
        document = paper_document(result)
        write_report(Path(staging), document, result, options, command)
    return document
