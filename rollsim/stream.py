"""Render, decode and evaluate frames in memory, without PNG files.

:class:`DecodedRun` renders a pipeline's frames one at a time, decodes each
and keeps only the truth records and decoded records (constant memory in the
images); :meth:`DecodedRun.evaluation` then gives every emitted PHY-SDU its
outcome. :func:`scene_outcomes` is the whole loop for a scene, with its
timings. The ``run`` stage of a sweep runs each cell through it; ``rollsim
bench stress`` and the decoder's tests, one scene each; ``rollsim bench
accuracy`` several fidelity settings side by side, a frame at a time.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rollsim.scene.model import Scene


class DecodedRun:
    """Frames of one pipeline, rendered and decoded as they are stepped through.

    Parameters
    ----------
    pipeline : RenderPipeline

    Attributes
    ----------
    truth : list of dict
        One truth record per frame stepped.
    decoded : list of dict
        Every decoded record (:meth:`decoder.DecodedPhySdu.to_record`).
    render_s, decode_s : list of float
        Seconds of ``pipeline.render`` and of the decoder, per frame.
    stripe_fractions : list of float
        With ``measure_stripes``: per frame, the fraction of rows in which
        the decoder reads the LED's stripes
        (:func:`decoder.stripe_row_fraction`, the measured ROI ratio), from
        the same decoding pass.
    """

    def __init__(self, pipeline, measure_stripes: bool = False):
        from rollsim.decode import settings_from_scene

        self.pipeline = pipeline
        self._settings = settings_from_scene(pipeline.setup.scene)
        self.truth: list[dict] = []
        self.decoded: list[dict] = []
        self.render_s: list[float] = []
        self.decode_s: list[float] = []
        self.measure_stripes = bool(measure_stripes)
        self.stripe_fractions: list[float] = []

    def step(self, index: int):
        """Render frame ``index``, time it, decode it; returns the rendered frame."""
        from decoder import decode_frame, inspect_frame, views_stripe_fraction

        start = time.perf_counter()
        frame = self.pipeline.render(index)
        middle = time.perf_counter()
        settings = self._settings
        decode_args = (frame.image, settings.phy, settings.clock_hz, settings.row_time_s, index)
        if self.measure_stripes:
            # One pass gives both: inspect_frame decodes as decode_frame does
            # (same options) and keeps where it read stripes.
            views = inspect_frame(*decode_args)
            found = [sdu for view in views for sdu in view.sdus]
            self.stripe_fractions.append(views_stripe_fraction(views, frame.image.shape[0]))
        else:
            found = decode_frame(*decode_args)
        self.decode_s.append(time.perf_counter() - middle)
        self.render_s.append(middle - start)
        self.truth.append(frame.truth)
        self.decoded.extend(sdu.to_record() for sdu in found)
        return frame

    def evaluation(self):
        """The outcome of every emission of the frames stepped (:func:`rollsim.evaluate.evaluate`)."""
        from rollsim.evaluate import evaluate

        return evaluate(self.truth, self.decoded, self.pipeline.setup.transmitter)


def fitted_mmbp(evaluation, truth: list[dict], scene: Scene) -> dict | None:
    """The MMBP fit of an evaluation's outcomes, as :func:`rollsim.calibrate.calibrate` gives it.

    Returns
    -------
    dict or None
        ``M``, ``N``, ``p_e``, ... (:meth:`MmbpFit.as_dict`), or None when
        the model cannot be fitted (no emission, or none succeeded).
    """
    from rollsim.calibrate import Trace, fit_mmbp

    outcomes = evaluation.outcomes
    trace = Trace(
        np.array([o["success"] for o in outcomes], dtype=bool),
        np.array([o["start_s"] for o in outcomes], dtype=np.float64),
        np.array([t["start_s"] for t in truth], dtype=np.float64),
        scene,
    )
    try:
        return fit_mmbp(trace).as_dict()
    except ValueError:
        return None


def scene_outcomes(scene: Scene, n_frames: int) -> dict:
    """Render, decode and evaluate ``n_frames`` of a scene in memory.

    Returns
    -------
    dict
        The evaluation summary (:func:`rollsim.evaluate.summarise`) plus
        ``render_ms_per_frame`` and ``decode_ms_per_frame`` (one core).
    """
    from rollsim.render import RenderPipeline

    run = DecodedRun(RenderPipeline(scene))
    for index in range(n_frames):
        run.step(index)
    summary = run.evaluation().summary
    summary["render_ms_per_frame"] = 1e3 * sum(run.render_s) / max(1, n_frames)
    summary["decode_ms_per_frame"] = 1e3 * sum(run.decode_s) / max(1, n_frames)
    return summary
