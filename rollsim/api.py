"""The Python API: rollsim's commands as functions, for notebooks and scripts.

The loop of the command line (``render``, ``decode``, ``evaluate``,
``calibrate``, ``simulate``, ``sweep``) in a few lines, with the same
results for the same scene and seed:

>>> import rollsim as rs
>>> scene = rs.load_scene("paper-default", overrides={"link.distance_cm": 10})
>>> frames = rs.render(scene, n_frames=8, seed=1)
>>> decoded = rs.decode(frames)
>>> result = rs.evaluate(frames.truth, decoded)
>>> result.counts["ok"] > 0
True
>>> fit = rs.calibrate(result)
>>> 0.0 <= fit.mmbp.p_message(r=3, strategy="rp") <= 1.0
True

Frames are rendered one at a time as they are iterated (constant memory);
:meth:`Frames.materialise` holds them. Truth records are typed
(:class:`FrameTruth`, :class:`SduTruth`); decoded records are the lines of
``decoded.jsonl`` (dicts), whichever decoder made them.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, Mapping, Optional, Sequence, Union

import numpy as np

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

__all__ = [
    "Calibration",
    "Frame",
    "FrameTruth",
    "Frames",
    "MmbpModel",
    "Result",
    "SduTruth",
    "Truth",
    "calibrate",
    "decode",
    "evaluate",
    "load_scene",
    "render",
    "simulate",
]

# ------------------------------------------------------------------- scenes


def _override_text(key: str, value: Any) -> str:
    """``KEY=VALUE`` as ``--set`` takes it; values other than strings as JSON (which YAML reads)."""
    return f"{key}={value if isinstance(value, str) else json.dumps(value)}"


def load_scene(scene: Union[str, Path, "Scene"], overrides: Optional[Mapping[str, Any]] = None,
               seed: Optional[int] = None) -> "Scene":
    """A validated scene: a bundled name, a YAML file or a scene, with overrides.

    Parameters
    ----------
    scene : str, Path or Scene
        A bundled scene's name (``rollsim scenes`` lists them), a YAML
        file, or a scene already loaded.
    overrides : mapping, optional
        ``{"link.distance_cm": 10, ...}``: the command line's ``--set``.
    seed : int, optional
        The scene's seed (its ``seed`` key), as ``--seed``.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        One line per problem, naming the file and field.

    Examples
    --------
    >>> import rollsim as rs
    >>> rs.load_scene("paper-default", overrides={"camera.exposure_us": 50}).camera.exposure_us
    50.0
    """
    from rollsim.scene import load_scene as load
    from rollsim.scene.model import Scene

    texts = [_override_text(k, v) for k, v in (overrides or {}).items()]
    if seed is not None:
        texts.append(_override_text("seed", seed))
    if isinstance(scene, Scene):
        if not texts:
            return scene
        from rollsim.scene import scene_from_dict, scene_to_dict

        return scene_from_dict(scene_to_dict(scene), scene.name, texts)
    return load(scene, texts)


# -------------------------------------------------------------------- truth


@dataclass(frozen=True)
class SduTruth:
    """One emitted PHY-SDU that overlaps a frame (a ``truth.jsonl`` ``sdus`` item).

    Attributes
    ----------
    tx : int
        Emission index.
    sequence : int
    bits, codeword : str
        Payload bits and the whole codeword, MSB first.
    start_s, end_s : float
        Emission span, seconds.
    first_row, last_row : int
        The rows that see this PHY-SDU and nothing else.
    first_row_f, last_row_f : float
        The rows centred on its first and last edge.
    fully_visible : bool
        Every chip of it integrated by some LED row.
    """

    tx: int
    sequence: int
    bits: str
    codeword: str
    start_s: float
    end_s: float
    first_row: int
    last_row: int
    first_row_f: float
    last_row_f: float
    fully_visible: bool


@dataclass(frozen=True)
class FrameTruth:
    """The ground truth of one frame (a ``truth.jsonl`` line).

    Attributes
    ----------
    frame : int
    start_s, row_time_s, exposure_s : float
        Frame start, row time and exposure, seconds.
    led_rows : tuple of int or None
        The LED's first and last row; None when it is out of the frame.
    sdus : tuple of SduTruth
    """

    frame: int
    start_s: float
    row_time_s: float
    exposure_s: float
    led_rows: Optional[tuple]
    sdus: tuple

    @classmethod
    def from_record(cls, record: Mapping) -> "FrameTruth":
        """From a ``truth.jsonl`` record."""
        rows = record.get("led_rows")
        return cls(int(record["frame"]), float(record["start_s"]), float(record["row_time_s"]),
                   float(record["exposure_s"]), tuple(rows) if rows else None,
                   tuple(SduTruth(**sdu) for sdu in record["sdus"]))

    def to_record(self) -> dict:
        """The ``truth.jsonl`` record."""
        return {"frame": self.frame, "start_s": self.start_s, "row_time_s": self.row_time_s,
                "exposure_s": self.exposure_s, "led_rows": list(self.led_rows) if self.led_rows else None,
                "sdus": [{f.name: getattr(sdu, f.name) for f in fields(SduTruth)} for sdu in self.sdus]}


class Truth(Sequence):
    """The truth of a run's frames, in frame order, with the scene they came from.

    Parameters
    ----------
    frames : sequence of FrameTruth
    scene : Scene
    """

    def __init__(self, frames: Sequence[FrameTruth], scene: "Scene"):
        self._frames = tuple(frames)
        self.scene = scene

    def __getitem__(self, index):
        return self._frames[index]

    def __len__(self) -> int:
        return len(self._frames)

    def to_records(self) -> list[dict]:
        """The ``truth.jsonl`` records."""
        return [frame.to_record() for frame in self._frames]

    def to_dataframe(self):
        """One row per (frame, PHY-SDU): the frame's columns, then the PHY-SDU's (needs pandas)."""
        import pandas as pd

        rows = [{"frame": f.frame, "frame_start_s": f.start_s, **{k.name: getattr(s, k.name) for k in fields(SduTruth)}}
                for f in self._frames for s in f.sdus]
        return pd.DataFrame(rows, columns=["frame", "frame_start_s", *(k.name for k in fields(SduTruth))])


# ------------------------------------------------------------------- frames


@dataclass(frozen=True)
class Frame:
    """A rendered frame: its index, image (uint8 or uint16 array) and truth."""

    index: int
    image: np.ndarray
    truth: FrameTruth


class Frames:
    """A scene's frames, rendered one at a time as they are iterated.

    Iterating renders each frame afresh (the same bytes every time: a
    frame depends only on the scene, its seed and its index), so memory
    stays flat however many frames there are. :attr:`truth` renders the
    frames not yet seen; :meth:`materialise` holds every frame in memory.

    Parameters
    ----------
    scene : Scene
    n_frames : int
    start : int
        Index of the first frame.
    """

    def __init__(self, scene: "Scene", n_frames: int, start: int = 0):
        if n_frames < 0 or start < 0:
            raise ValueError(f"n_frames and start must be >= 0, got {n_frames} and {start}")
        self.scene = scene
        self.n_frames = int(n_frames)
        self.start = int(start)
        self._truth: dict[int, FrameTruth] = {}
        self._pipeline: Any = None

    def __len__(self) -> int:
        return self.n_frames

    def _render(self, index: int) -> Frame:
        if self._pipeline is None:
            from rollsim.render import RenderPipeline

            self._pipeline = RenderPipeline(self.scene)
        rendered = self._pipeline.render(index)
        truth = self._truth.get(index) or FrameTruth.from_record(rendered.truth)
        self._truth[index] = truth
        return Frame(rendered.index, rendered.image, truth)

    def __iter__(self) -> Iterator[Frame]:
        for index in range(self.start, self.start + self.n_frames):
            yield self._render(index)

    @property
    def truth(self) -> Truth:
        """The truth of every frame (rendering those not yet seen)."""
        for index in range(self.start, self.start + self.n_frames):
            if index not in self._truth:
                self._render(index)
        return Truth([self._truth[i] for i in range(self.start, self.start + self.n_frames)], self.scene)

    def materialise(self) -> list[Frame]:
        """Every frame, held in memory (checked against the machine's memory first)."""
        from rollsim.render.pipeline import check_render_memory

        check_render_memory(self.scene, frames_held=self.n_frames)
        return list(self)


def render(scene: Union[str, Path, "Scene"], n_frames: Optional[int] = None, seed: Optional[int] = None,
           start: int = 0) -> Frames:
    """Frames of a scene, as ``rollsim render`` writes them (without the PNG files).

    Parameters
    ----------
    scene : str, Path or Scene
        See :func:`load_scene`.
    n_frames : int, optional
        Default: the scene's ``frames``.
    seed : int, optional
        Default: the scene's ``seed``.
    start : int
        Index of the first frame.

    Returns
    -------
    Frames
        Iterable frame by frame (constant memory).

    Examples
    --------
    >>> import rollsim as rs
    >>> frames = rs.render("paper-default", n_frames=2)
    >>> [frame.image.shape for frame in frames]
    [(1080, 1920), (1080, 1920)]
    >>> frames.truth[0].sdus[0].fully_visible in (True, False)
    True
    """
    loaded = load_scene(scene, seed=seed)
    return Frames(loaded, loaded.frames if n_frames is None else n_frames, start)


# ------------------------------------------------------------------- decode

Decoder = Callable[[np.ndarray, Any], Iterable]


def rollsim_decoder(image: np.ndarray, settings) -> list:
    """rollsim's own decoder (:func:`decoder.decode_frame`) as a ``decoder=`` callable."""
    from decoder import decode_frame

    return decode_frame(image, settings.phy, settings.clock_hz, settings.row_time_s, exposure_s=settings.exposure_s)


def decode(frames: Union[Frames, Iterable], scene: Union[str, Path, "Scene", None] = None,
           decoder: Optional[Decoder] = None) -> list[dict]:
    """Decode frames into ``decoded.jsonl`` records, as ``rollsim decode`` does.

    Parameters
    ----------
    frames : Frames or iterable of Frame or of ndarray
        Arrays are numbered from 0.
    scene : str, Path or Scene, optional
        The link and camera the decoder is told of; default the frames'
        scene (required for arrays).
    decoder : callable, optional
        ``decoder(image, settings) -> iterable of records``, ``settings`` a
        :class:`rollsim.decode.DecodeSettings` (``phy``, ``clock_hz``,
        ``row_time_s``); a record is a :class:`decoder.DecodedPhySdu` or a
        dict with the fields of ``decoded.jsonl`` (checked against its
        schema, :mod:`rollsim.records`). Default: rollsim's.

    Returns
    -------
    list of dict
        One record per PHY-SDU found, in frame order.

    Examples
    --------
    >>> import rollsim as rs
    >>> frames = rs.render("paper-geometric", n_frames=2)
    >>> records = rs.decode(frames)
    >>> sorted(records[0])[:4], records[0]["frame"]
    (['bits', 'check_ok', 'confidence', 'first_row'], 0)
    >>> rs.decode(frames, decoder=lambda image, settings: [])
    []
    """
    from rollsim.decode import settings_from_scene
    from rollsim.records import as_decoded_record

    chosen = scene if scene is not None else getattr(frames, "scene", None)
    if chosen is None:
        raise ValueError("decode: give scene= for frames that are arrays")
    settings = settings_from_scene(load_scene(chosen))
    run = decoder if decoder is not None else rollsim_decoder
    records: list[dict] = []
    for number, item in enumerate(frames):
        index, image = (item.index, item.image) if isinstance(item, Frame) else (number, np.asarray(item))
        records.extend(as_decoded_record(found, index) for found in run(image, settings))
    return records


# ----------------------------------------------------------------- evaluate


class Result:
    """Every emission's outcome, the false decodes and the rates of a run.

    Attributes
    ----------
    outcomes : list of dict
        One per emission in tx order (``outcomes.csv``'s columns).
    false_decodes : list of dict
        Decoded records that match no emission.
    summary : dict
        As ``evaluation.json``: ``counts``, ``error_rate``, ...
    truth : Truth
    """

    def __init__(self, evaluation, truth: Truth):
        self.outcomes = evaluation.outcomes
        self.false_decodes = evaluation.false_decodes
        self.summary = evaluation.summary
        self.truth = truth

    @property
    def counts(self) -> dict:
        """Emissions per outcome (``ok``, ``corrupted``, ``missed``, ...)."""
        return dict(self.summary["counts"])

    @property
    def scene(self) -> "Scene":
        return self.truth.scene

    def trace(self):
        """The success trace in emission order, with times and scene (:class:`rollsim.calibrate.Trace`)."""
        from rollsim.calibrate import Trace

        return Trace.from_outcomes(self.outcomes, self.truth, self.scene, "<rollsim.evaluate>")

    def to_dataframe(self):
        """The outcomes as a table (needs pandas)."""
        import pandas as pd

        from rollsim.evaluate import OUTCOME_COLUMNS

        return pd.DataFrame(self.outcomes, columns=list(OUTCOME_COLUMNS))


def evaluate(truth: Union[Truth, Frames], decoded: Sequence[Mapping]) -> Result:
    """Give every emission its outcome, as ``rollsim evaluate`` does.

    Parameters
    ----------
    truth : Truth or Frames
        ``frames.truth`` (it carries the scene).
    decoded : sequence of dict
        ``decoded.jsonl`` records, e.g. from :func:`decode`.

    Returns
    -------
    Result

    Examples
    --------
    >>> import rollsim as rs
    >>> frames = rs.render("paper-geometric", n_frames=3)
    >>> result = rs.evaluate(frames.truth, rs.decode(frames))
    >>> sorted(result.counts)
    ['corrupted', 'missed', 'not_visible', 'ok', 'undetected_error']
    >>> result.counts["ok"] <= result.summary["fully_visible"]
    True
    """
    from rollsim.evaluate import evaluate as run
    from rollsim.transmitter import transmitter_from_scene

    if isinstance(truth, Frames):
        truth = truth.truth
    records = [dict(d) for d in decoded]
    return Result(run(truth.to_records(), records, transmitter_from_scene(truth.scene)), truth)


# ---------------------------------------------------------------- calibrate


@dataclass(frozen=True)
class MmbpModel:
    """A fitted MMBP channel and the message size it serves.

    Attributes
    ----------
    fit : rollsim.calibrate.mmbp.MmbpFit
        M, N, p_e with its 95 % interval, log-likelihood, ...
    n_packets : int
        N_p, the message's PHY-SDUs.
    """

    fit: Any
    n_packets: int

    @property
    def M(self) -> int:
        return self.fit.M

    @property
    def N(self) -> int:
        return self.fit.N

    @property
    def p_e(self) -> float:
        return self.fit.p_e

    def p_message(self, r: int, strategy: str = "rp", n_packets: Optional[int] = None) -> float:
        """Probability that one message round delivers every PHY-SDU (exact, log space).

        Parameters
        ----------
        r : int
            Repeats.
        strategy : {"rp", "rs"}
        n_packets : int, optional
            Default :attr:`n_packets`.
        """
        from rollsim.channel.analytic import mmbp_p_message

        n = self.n_packets if n_packets is None else n_packets
        return float(mmbp_p_message(self.M, self.N, r, self.p_e, n, strategy))


@dataclass(frozen=True)
class Calibration:
    """The channel models fitted to a run (``rollsim calibrate``).

    Attributes
    ----------
    mmbp : MmbpModel
    ge : rollsim.calibrate.ge.GeFit
    report : dict
        Everything ``calibration.json`` holds: criteria, run lengths,
        whole-message curves, the physics' prediction.
    """

    mmbp: MmbpModel
    ge: Any
    report: dict


def calibrate(result: Result, n_packets: Optional[int] = None, seed: int = 1) -> Calibration:
    """Fit the MMBP and Gilbert-Elliott models to a run's outcomes.

    Parameters
    ----------
    result : Result
    n_packets : int, optional
        N_p for the message probabilities; default the scene's.
    seed : int
        Seed of the model simulations behind the run-length comparison.

    Raises
    ------
    RollsimError
        When the models cannot be fitted (no emission, none received).

    Examples
    --------
    >>> import rollsim as rs
    >>> frames = rs.render("paper-geometric", n_frames=6)
    >>> fit = rs.calibrate(rs.evaluate(frames.truth, rs.decode(frames)))
    >>> fit.mmbp.M >= 1 and 0.0 <= fit.mmbp.p_e <= 1.0
    True
    >>> low, high = fit.mmbp.fit.p_e_ci95          # Clopper-Pearson 95 % interval
    >>> low <= fit.mmbp.p_e <= high
    True
    """
    from rollsim.calibrate import calibrate as run
    from rollsim.calibrate import fit_ge, fit_mmbp

    trace = result.trace()
    report = run(trace, n_packets, seed)
    n = report["message"]["n_packets"]
    return Calibration(MmbpModel(fit_mmbp(trace), n), fit_ge(trace.success), report)


# ----------------------------------------------------------------- simulate


def simulate(scene: Union[str, Path, "Scene"], channel: str = "mmbp", runs: int = 1000, seed: Optional[int] = None,
             workers: Optional[int] = 1):
    """Simulate the scene's broadcast on a channel model, as ``rollsim simulate``.

    Parameters
    ----------
    scene : str, Path or Scene
    channel : {"mmbp", "timed", "camcomsim"}
    runs : int
    seed : int, optional
        Default the scene's.
    workers : int, optional
        Processes (None: every core).

    Returns
    -------
    rollsim.channel.eventsim.BroadcastResult
        ``.summary()`` gives goodput and duration with 95 % intervals.

    Examples
    --------
    >>> import rollsim as rs
    >>> summary = rs.simulate("paper-default", runs=20).summary()
    >>> summary["runs"]
    20
    """
    from rollsim.channel.scene_channel import scene_relaxations, simulate_scene
    from rollsim.scene import load_scene as load

    loaded = scene if not isinstance(scene, (str, Path)) else load(scene, relax=scene_relaxations(channel))
    return simulate_scene(loaded, channel, runs=runs, seed=seed, workers=workers)
