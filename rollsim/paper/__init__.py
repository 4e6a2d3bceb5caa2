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
from typing import TYPE_CHECKING, Callable, Mapping, NamedTuple, Optional

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

__all__ = ["PaperOptions", "cluster_tasks", "compute_comparisons", "run_paper"]


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


# Claims whose pixel figure needs the decoder's stripe rows measured.
ROI_QUANTITIES = ("ROI ratio", "throughput")


class ClusterTask(NamedTuple):
    """One computation on the cluster and the settings it serves.

    Attributes
    ----------
    layer : str
        ``"pixel"``, ``"event"`` or ``"camcomsim"``.
    keys : tuple of str
        The settings (:func:`rollsim.paper.experiments.settings`) whose
        scenes resolve to the same one: each gets the result.
    function : callable
    args : tuple
    """

    layer: str
    keys: tuple
    function: Callable
    args: tuple


def cluster_tasks(options: PaperOptions, scenes: Mapping[str, Scene]) -> list[ClusterTask]:
    """The pixel, event and CamComSim computations of every claimed setting, each scene once.

    Settings named differently may resolve to the same scene (the 1 kB
    message at 5 cm with one repeat is both Fig. 15's and Fig. 18's): they
    share one computation, as the same scene and seed give the same
    figures. A pixel task measures the ROI only where a setting it serves
    has a ROI or throughput claim.

    Parameters
    ----------
    options : PaperOptions
    scenes : mapping of str to Scene
        Every claimed setting's scene (:func:`rollsim.paper.layers.load`
        of its overrides).
    """
    from rollsim.paper.experiments import claims, settings
    from rollsim.paper.layers import pixel_figures
    from rollsim.scene import scene_to_yaml

    all_settings = settings()
    wanted = sorted({key for _, key in claims()})
    needs_roi = {key for claim, key in claims() if claim.quantity in ROI_QUANTITIES}
    # The resolved scene, not the overrides' spelling, tells two settings apart.
    identity = {key: scene_to_yaml(scenes[key]) for key in wanted}
    # Per task (layer, scene, extra overrides, count): the first setting's arguments and every setting served.
    grouped: dict[tuple, tuple[tuple, list[str]]] = {}

    def add(layer: str, key: str, overrides: tuple, count: int, extra: tuple = ()) -> None:
        grouped.setdefault((layer, identity[key], extra, count), (((*overrides, *extra), count), []))[1].append(key)

    for key in wanted:
        setting = all_settings[key]
        if setting.pixel and (setting.quick_pixel or not options.quick):
            add("pixel", key, setting.overrides, max(1, round(options.frames * setting.frames_factor)))
    for key in wanted:
        setting = all_settings[key]
        add("event", key, setting.overrides, options.runs)
        if setting.camcomsim:
            add("camcomsim", key, setting.overrides, options.runs, tuple(setting.camcomsim_overrides))
    functions: dict[str, Callable[..., dict]] = {"pixel": pixel_figures, "event": _mmbp_figures,
                                                 "camcomsim": _camcomsim_figures}
    tasks = []
    for (layer, *_), (args, keys) in grouped.items():
        if layer == "pixel":
            args = (*args, any(key in needs_roi for key in keys))
        tasks.append(ClusterTask(layer, tuple(keys), functions[layer], args))
    return tasks


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
    from rollsim.paper.layers import analytic_figures, load

    say = progress or (lambda text: None)
    start = time.perf_counter()
    all_settings = settings()
    wanted = {key for _, key in claims()}
    scenes = {key: load(all_settings[key].overrides) for key in wanted}
    tasks = cluster_tasks(options, scenes)
    futures = {client.submit(task.function, *task.args, pure=False): task for task in tasks}
    r_values = range(1, 7)
    one_round = client.submit(_one_round_fractions, 3, 2, 0.001, 22, r_values, options.runs, 1, pure=False)
    figures = {key: {"analytic": analytic_figures(scene)} for key, scene in scenes.items()}
    say(f"{len(futures)} settings on the cluster")
    for done, future in enumerate(as_completed(list(futures), loop=client.loop), 1):
        task = futures[future]
        result = future.result()
        for key in task.keys:
            figures[key][task.layer] = result
        say(f"[{done}/{len(futures)}] {', '.join(task.keys)} {task.layer}")
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
