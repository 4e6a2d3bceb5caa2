"""``rollsim run``: the whole loop on one scene.

render and decode → evaluate → calibrate → report, into one output
directory that appears only when every stage is done
(:mod:`rollsim.plumbing.outputs`):

- ``frames/``, ``truth.jsonl``, ``scene.resolved.yaml``, ``decoded.jsonl``,
  ``decode.json`` (render and decode: each frame is decoded in the worker
  that rendered it, from the image it has just written, the same records
  ``rollsim decode`` reads from the PNG, without reading it back)
- ``outcomes.csv``, ``evaluation.json`` (evaluate)
- ``calibration.json`` (calibrate)
- ``report.md`` and ``plots/*.png`` (report)
"""

from __future__ import annotations

import contextlib
import json
import time
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable, Optional

from rollsim.errors import RollsimError
from rollsim.plumbing.outputs import staged_directory

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

STAGES = ("render and decode", "evaluate", "calibrate", "report")
# What the stages after the render import (SciPy's optimiser, matplotlib: about
# 0.9 s in a fresh process), imported while the workers render.
LATER_MODULES = ("rollsim.calibrate", "rollsim.report", "matplotlib.figure", "matplotlib.backends.backend_agg")


@dataclass(frozen=True)
class RunSummary:
    """What a run produced.

    Attributes
    ----------
    out_dir : Path
    frames : int
    evaluation : dict
        The evaluation summary.
    calibration : dict or None
        The calibration result; None when the trace could not be fitted.
    timings : dict
        Seconds per stage.
    calibration_error : str or None
        Why there is no calibration.
    """

    out_dir: Path
    frames: int
    evaluation: dict
    calibration: Optional[dict]
    timings: dict
    calibration_error: Optional[str] = None


class _StageClock:
    """Times consecutive stages and reports each start and end."""

    def __init__(self, on_stage: Optional[Callable[[str, str], None]]):
        self.timings: dict[str, float] = {}
        self._on_stage = on_stage

    def run(self, stage: str, work: Callable):
        if self._on_stage is not None:
            self._on_stage(stage, "start")
        start = time.perf_counter()
        try:
            return work()
        finally:
            # A stage that fails (calibration of a dark scene) is timed too.
            self.timings[stage] = time.perf_counter() - start
            if self._on_stage is not None:
                self._on_stage(stage, "done")


def drawn_beside(future: Future) -> list:
    """The figures a second process drew (``(title, path)`` pairs), once it has."""
    return future.result()


def run_scene(
    scene: Scene,
    out_dir: Path,
    n_frames: int,
    *,
    force: bool = False,
    workers: int = 1,
    on_stage: Optional[Callable[[str, str], None]] = None,
    on_frame: Optional[Callable[[str, int], None]] = None,
    on_skipped: Optional[Callable[[dict], None]] = None,
    inputs: Iterable = (),
) -> RunSummary:
    """Render, decode, evaluate, calibrate and report one scene.

    Parameters
    ----------
    scene : Scene
    out_dir : Path
        Must not exist or be empty, unless ``force``.
    n_frames : int
    force : bool
        Replace a non-empty ``out_dir``.
    workers : int
        Processes for rendering and decoding.
    on_stage : callable, optional
        ``on_stage(stage, "start" | "done")``.
    on_frame : callable, optional
        ``on_frame(stage, frames_done)`` during render and decode.
    on_skipped : callable, optional
        Called with the record of each frame the decoder could not read.
    inputs : iterable of path, optional
        The command's input files, which ``out_dir`` must not hold.

    A trace the models cannot be fitted to (nothing decoded, a dark scene)
    still gives a run: everything but ``calibration.json``, with the reason
    in the report and in :attr:`RunSummary.calibration_error`.

    Raises
    ------
    RollsimError
        An impossible scene, an unusable output directory, or (exit code 1)
        an OS failure while writing; ``out_dir`` is then left as it was.
    """
    from rollsim.plumbing.parallel import process_pool
    from rollsim.plumbing.preload import preloading
    from rollsim.stages.decode import (DECODED_NAME, SUMMARY_NAME, DecodedRecords, DecodeSummary, FrameDecoder,
                                       settings_from_scene, summary_text)
    from rollsim.stages.records import scene_run_identifier
    from rollsim.stages.evaluate import evaluate_directory
    from rollsim.render.pipeline import check_render_memory
    from rollsim.render.writer import check_render_disk, prepare_render, render_into

    if n_frames < 1:
        raise ValueError(f"n_frames must be >= 1, got {n_frames}")
    check_render_memory(scene, workers)
    check_render_disk(scene, n_frames, Path(out_dir))
    prepare_render(scene)  # fails on an impossible scene before touching disk; the render's own pipeline
    clock = _StageClock(on_stage)

    def progress(stage):
        return None if on_frame is None else (lambda done: on_frame(stage, done))

    settings = settings_from_scene(scene)
    decode = FrameDecoder(settings, scene_run_identifier(scene))
    with staged_directory(Path(out_dir), force, inputs) as staging, preloading(LATER_MODULES) as preload:
        summary = DecodeSummary(settings, frames=n_frames)
        with open(staging / DECODED_NAME, "w", encoding="utf-8") as decoded:
            written = DecodedRecords(decoded, summary, staging, on_skipped)

            def on_decoded(result) -> None:
                written.add(*result)
                if workers > 1:  # the workers have forked (see rollsim.plumbing.preload)
                    preload.start()

            clock.run("render and decode", lambda: render_into(scene, staging, n_frames, workers,
                                                               progress("render and decode"), decode=decode,
                                                               on_decoded=on_decoded))
        (staging / SUMMARY_NAME).write_text(summary_text(summary), encoding="utf-8")
        evaluation = clock.run("evaluate", lambda: evaluate_directory(staging))
        preload.join()  # before the fork below, and the imports below find the modules loaded
        from rollsim.calibrate import calibrate, load_trace
        from rollsim.report import calibration_plot_names, draw_calibration_plots, draw_frame_plots, write_report

        reason: Optional[str] = None
        with contextlib.ExitStack() as beside:
            # With workers, one more process draws the plots of the frames
            # while the calibration runs (they need none), then the later
            # calibration plots while this one draws the first.
            pool = beside.enter_context(process_pool(1)) if workers > 1 else None
            frames_drawn = None if pool is None else pool.submit(draw_frame_plots, staging, scene, evaluation)
            try:
                calibration = clock.run("calibrate", lambda: calibrate(load_trace(staging, source=str(out_dir))))
            except RollsimError as exc:
                # Nothing decoded (a dark or undecodable scene) is a finding, not
                # bad input: the run still reports what the decoder saw. A file's
                # error names the temporary directory: name the run's.
                calibration, reason = None, str(exc).replace(str(staging), str(out_dir))
            else:
                (staging / "calibration.json").write_text(json.dumps(calibration, indent=2, allow_nan=False) + "\n",
                                                          encoding="utf-8")

            def report() -> None:
                if pool is None or frames_drawn is None:
                    write_report(staging, scene, evaluation, calibration, clock.timings, reason)
                    return
                names = calibration_plot_names(calibration)
                later = pool.submit(draw_calibration_plots, staging, calibration, names[1:])
                first = draw_calibration_plots(staging, calibration, names[:1])
                write_report(staging, scene, evaluation, calibration, clock.timings, reason,
                             frame_figures=drawn_beside(frames_drawn), calibration_figures=first + drawn_beside(later))

            clock.run("report", report)
    return RunSummary(Path(out_dir), n_frames, evaluation.summary, calibration, clock.timings, reason)
