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
    other_decoded : list of dict
        With ``other_decoder`` (``package.module:function``, see
        :func:`rollsim.stages.decode.load_decoder`): its records of the same
        frames, and ``other_decode_s`` its seconds per frame.
    """

    def __init__(self, pipeline, measure_stripes: bool = False, other_decoder: str | None = None):
        from rollsim.stages.decode import load_decoder, settings_from_scene

        self.pipeline = pipeline
        self._settings = settings_from_scene(pipeline.setup.scene)
        self.truth: list[dict] = []
        self.decoded: list[dict] = []
        self.render_s: list[float] = []
        self.decode_s: list[float] = []
        self.measure_stripes = bool(measure_stripes)
        self.stripe_fractions: list[float] = []
        self._other = load_decoder(other_decoder) if other_decoder is not None else None
        self.other_decoded: list[dict] = []
        self.other_decode_s: list[float] = []

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
            views = inspect_frame(*decode_args, exposure_s=settings.exposure_s)
            found = [sdu for view in views for sdu in view.sdus]
            self.stripe_fractions.append(views_stripe_fraction(views, frame.image.shape[0]))
        else:
            found = decode_frame(*decode_args, exposure_s=settings.exposure_s)
        self.decode_s.append(time.perf_counter() - middle)
        self.render_s.append(middle - start)
        self.truth.append(frame.truth)
        self.decoded.extend(sdu.to_record() for sdu in found)
        if self._other is not None:
            from rollsim.stages.records import as_decoded_record

            start = time.perf_counter()
            self.other_decoded.extend(as_decoded_record(f, index) for f in self._other(frame.image, settings))
            self.other_decode_s.append(time.perf_counter() - start)
        return frame

    def evaluation(self, other: bool = False):
        """The outcome of every emission of the frames stepped (:func:`rollsim.stages.evaluate.evaluate`).

        With ``other``, of the other decoder's records.
        """
        from rollsim.stages.evaluate import evaluate

        return evaluate(self.truth, self.other_decoded if other else self.decoded, self.pipeline.setup.transmitter)


def fitted_mmbp(evaluation, truth: list[dict], scene: Scene) -> dict | None:
    """The MMBP fit of an evaluation's outcomes, as :func:`rollsim.calibrate.calibrate` gives it.

    Returns
    -------
    dict or None
        ``M``, ``N``, ``p_e``, ... (:meth:`MmbpFit.as_dict`), or None when
        the model cannot be fitted (no emission, or none succeeded).
    """
    from rollsim.calibrate import Trace, fit_mmbp

    trace = Trace.from_outcomes(evaluation.outcomes, truth, scene)
    try:
        return fit_mmbp(trace).as_dict()
    except ValueError:
        return None


def scene_outcomes(scene: Scene, n_frames: int, other_decoder: str | None = None) -> dict:
    """Render, decode and evaluate ``n_frames`` of a scene in memory.

    Parameters
    ----------
    scene : Scene
    n_frames : int
    other_decoder : str, optional
        ``package.module:function``: also decode the same frames with it.

    Returns
    -------
    dict
        The evaluation summary (:func:`rollsim.stages.evaluate.summarise`) plus
        ``render_ms_per_frame`` and ``decode_ms_per_frame`` (one core); with
        ``other_decoder``, ``other``: its summary and ``decode_ms_per_frame``.
    """
    from rollsim.render import RenderPipeline

    run = DecodedRun(RenderPipeline(scene), other_decoder=other_decoder)
    for index in range(n_frames):
        run.step(index)
    summary = run.evaluation().summary
    summary["render_ms_per_frame"] = 1e3 * sum(run.render_s) / max(1, n_frames)
    summary["decode_ms_per_frame"] = 1e3 * sum(run.decode_s) / max(1, n_frames)
    if other_decoder is not None:
        other = run.evaluation(other=True).summary
        other["decode_ms_per_frame"] = 1e3 * sum(run.other_decode_s) / max(1, n_frames)
        summary["other"] = other
    return summary
