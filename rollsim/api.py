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

Each object shows its key figures: its repr is one line, and a notebook
shows them as a small table (``_repr_html_``):

>>> result                                                  # doctest: +ELLIPSIS
<Result 'paper-default': PHY-SDUs emitted ..., ok ..., goodput ... bit/s...>
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, Mapping, Optional, Sequence, Union, cast

import numpy as np

from rollsim.errors import ApiArgumentError, ApiTypeError, ApiValueError, RollsimError, clip, short_repr
from rollsim.plumbing.text_tables import Shown, quantity
from rollsim.plumbing.validation import MAX_COUNT

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

__all__ = [
    "AnnotatedFrame",
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
    "show",
    "simulate",
    "sweep",
]

# ---------------------------------------------------------- argument checks

# The most frames one call renders: the bound of the scene's ``frames`` key.
MAX_FRAMES = 10**9
# Seeds are 63-bit, as the scene's ``seed`` key.
SEED_LIMIT = 2**63
SCENE_EXPECTED = "a bundled scene name (rollsim scenes lists them), a YAML file or a Scene (from rollsim.load_scene)"


class _Arguments:
    """The argument checks of one API function or method.

    Each check returns the value (as the function uses it) or raises an
    :class:`~rollsim.errors.ApiTypeError` (wrong type) or
    :class:`~rollsim.errors.ApiValueError` (wrong value) whose one line names
    the function and the argument, what was expected and what was given
    (quoted short, so that a huge value costs nothing to report).

    Parameters
    ----------
    where : str
        The function as the user calls it: ``"render"``, ``"MmbpModel.p_message"``.
    """

    def __init__(self, where: str):
        self.where = where

    def error(self, name: str, text: str, kind: type = ApiValueError) -> ApiArgumentError:
        """``rollsim.WHERE: NAME: TEXT`` as an error of ``kind``."""
        return kind(f"rollsim.{self.where}: {name}: {text}")

    def refuse(self, name: str, expected: str, value, kind: type = ApiTypeError) -> ApiArgumentError:
        """``rollsim.WHERE: NAME: expected EXPECTED, got VALUE`` as an error of ``kind``."""
        return self.error(name, f"expected {expected}, got {short_repr(value)}", kind)

    def instance(self, name: str, value, types, expected: str):
        """``value`` if it is one of ``types``."""
        if not isinstance(value, types):
            raise self.refuse(name, expected, value)
        return value

    def integer(self, name: str, value, minimum: int = 0, maximum: int = MAX_COUNT, optional: bool = False):
        """``value`` as an int in [minimum, maximum]; numpy integers pass, bools and floats do not."""
        if value is None and optional:
            return None
        expected = f"an integer from {minimum} to {_bound_text(maximum)}"
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise self.refuse(name, expected, value)
        if not minimum <= value <= maximum:
            raise self.refuse(name, expected, value, ApiValueError)
        return int(value)

    def seed(self, name: str, value, optional: bool = False):
        """``value`` as a seed: an int in [0, 2**63)."""
        return self.integer(name, value, 0, SEED_LIMIT - 1, optional)

    def positive(self, name: str, value, optional: bool = False, at_most: float = math.inf) -> Optional[float]:
        """``value`` as a finite float > 0 (and <= ``at_most``); NaN, inf and bools refused."""
        if value is None and optional:
            return None
        expected = "a finite number > 0" + (f" and at most {at_most:g}" if math.isfinite(at_most) else "")
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise self.refuse(name, expected, value)
        try:
            number = float(value)
        except OverflowError:  # an int beyond a float's range
            number = math.inf
        if not (math.isfinite(number) and 0 < number <= at_most):
            raise self.refuse(name, expected, value, ApiValueError)
        return number

    def choice(self, name: str, value, choices: Sequence[str]) -> str:
        """``value`` if it is one of the strings ``choices``."""
        expected = f"one of {', '.join(repr(c) for c in choices)}"
        if not isinstance(value, str):
            raise self.refuse(name, expected, value)
        if value not in choices:
            raise self.refuse(name, expected, value, ApiValueError)
        return value

    def flag(self, name: str, value) -> bool:
        """``value`` as a bool (True, False or a numpy bool)."""
        return bool(self.instance(name, value, (bool, np.bool_), "True or False"))

    def path(self, name: str, value, expected: str = "a path (str or Path)") -> Union[str, Path]:
        """``value`` if it is a non-blank str or path without NUL characters."""
        text = os.fspath(value) if isinstance(value, os.PathLike) else value
        if not isinstance(text, str):
            raise self.refuse(name, expected, value)
        # The OS refuses a NUL in a name with a bare ValueError, and a blank
        # name would read as the working directory.
        if not text.strip() or "\0" in text:
            raise self.refuse(name, expected, value, ApiValueError)
        return value

    def scene(self, name: str, value):
        """``value`` if it is a Scene, a bundled scene's name or a scene file."""
        from rollsim.scene.model import Scene

        return value if isinstance(value, Scene) else self.path(name, value, SCENE_EXPECTED)

    def iterable(self, name: str, value, expected: str):
        """``value`` if it is iterable and not a string or mapping (whose items are not records)."""
        if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Iterable):
            raise self.refuse(name, expected, value)
        return value

    def callable(self, name: str, value, expected: str):
        """``value`` if it is callable or None."""
        if value is not None and not callable(value):
            raise self.refuse(name, expected, value)
        return value

    def texts(self, name: str, value) -> list[str]:
        """Scene overrides as ``KEY=VALUE`` texts: from a mapping, or (sweep's) an iterable of such texts."""
        if value is None:
            return []
        if isinstance(value, Mapping):
            return [self.override_text(name, key, item) for key, item in value.items()]
        expected = "a mapping of scene keys to values, e.g. {'link.distance_cm': 10}"
        return [self.instance(f"{name}[{n}]", text, str, "a KEY=VALUE text")
                for n, text in enumerate(self.iterable(name, value, expected))]

    def override_text(self, name: str, key, value) -> str:
        """``KEY=VALUE`` as ``--set`` takes it; values other than strings as JSON (which YAML reads)."""
        key = self.instance(f"{name} key", key, str, "a scene key (str), e.g. 'link.distance_cm'")
        if not key.strip() or "=" in key:
            raise self.refuse(f"{name} key", "a scene key, e.g. 'link.distance_cm'", key, ApiValueError)
        if isinstance(value, str):
            return f"{key}={value}"
        shown = f"{name}[{clip(repr(key), 40)}]"
        try:
            return f"{key}={json.dumps(value, allow_nan=False, default=_plain)}"
        except ValueError:
            raise self.refuse(shown, "finite numbers", value, ApiValueError) from None
        except TypeError:
            raise self.refuse(shown, "a number, str, bool, None, or a list or dict of them", value) from None


# Bounds as an error line shows them: 2**53 reads better than its 16 digits.
_BOUND_TEXT = {MAX_COUNT: "2**53", SEED_LIMIT - 1: "2**63 - 1"}


def _bound_text(bound: int) -> str:
    """A bound as an error line shows it."""
    return _BOUND_TEXT.get(bound, str(bound))


def _plain(value):
    """A numpy scalar or array as the Python value JSON writes; anything else refused."""
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    raise TypeError(type(value).__name__)


# ------------------------------------------------------------------- scenes


def _load(args: _Arguments, name: str, scene, texts: Sequence[str] = (), relax: Sequence[str] = ()) -> "Scene":
    """The scene ``scene`` (checked as argument ``name``) with the overrides ``texts``."""
    from rollsim.scene import load_scene as load
    from rollsim.scene import scene_from_dict, scene_to_dict
    from rollsim.scene.bundled import SceneNameError
    from rollsim.scene.model import Scene

    scene = args.scene(name, scene)
    if isinstance(scene, Scene):
        return scene_from_dict(scene_to_dict(scene), scene.name, texts, relax=relax) if texts else scene
    try:
        return load(scene if isinstance(scene, str) else Path(os.fspath(scene)), texts, relax=relax)
    except SceneNameError as exc:  # a name the OS will not look up (too long, ...): the user's value
        raise args.error(name, f"cannot read {short_repr(scene)} ({str(exc).rsplit('(', 1)[-1].rstrip(')')})") from None
    except OSError as exc:
        raise args.error(name, f"cannot read {short_repr(scene)} ({exc.strerror or exc})") from None


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
    ApiTypeError, ApiValueError
        An argument of the wrong type or value (a ``TypeError`` and a
        ``ValueError``), naming it.

    Examples
    --------
    >>> import rollsim as rs
    >>> rs.load_scene("paper-default", overrides={"camera.exposure_us": 50}).camera.exposure_us
    50.0
    >>> rs.load_scene(None)
    Traceback (most recent call last):
    ...
    rollsim.errors.ApiTypeError: rollsim.load_scene: scene: expected a bundled scene name (rollsim scenes lists them), a YAML file or a Scene (from rollsim.load_scene), got None
    """
    args = _Arguments("load_scene")
    args.scene("scene", scene)
    texts = args.texts("overrides", args.instance("overrides", overrides, (Mapping, type(None)),
                                                  "a mapping of scene keys to values, e.g. {'link.distance_cm': 10}"))
    seed = args.seed("seed", seed, optional=True)
    if seed is not None:
        texts.append(f"seed={seed}")
    return _load(args, "scene", scene, texts)


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


_TRUTH_KEYS = ("frame", "start_s", "row_time_s", "exposure_s", "sdus")


def _sdu_figures(truth: "FrameTruth") -> list[tuple[str, object]]:
    """A frame's PHY-SDUs and LED rows, as its repr shows them."""
    rows = truth.led_rows
    visible = sum(1 for sdu in truth.sdus if sdu.fully_visible)
    return [("PHY-SDUs", f"{len(truth.sdus)} ({visible} fully visible)"),
            ("LED rows", "none" if not rows else f"{rows[0]}..{rows[-1]}")]


@dataclass(frozen=True, repr=False)
class FrameTruth(Shown):
    """The ground truth of one frame (a ``truth.jsonl`` line).

    Attributes
    ----------
    frame : int
    start_s, row_time_s, exposure_s : float
        Frame start, row time and exposure, seconds.
    led_rows : tuple of int or None
        The LED's first and last row; None when it is out of the frame.
    sdus : tuple of SduTruth
    led_centre_px : tuple of float or None
        Where the frame shows the LED's centre (x, y), px, when the scene
        moves it (``motion``); None otherwise.
    """

    frame: int
    start_s: float
    row_time_s: float
    exposure_s: float
    led_rows: Optional[tuple]
    sdus: tuple
    led_centre_px: Optional[tuple] = None

    @classmethod
    def from_record(cls, record: Mapping) -> "FrameTruth":
        """From a ``truth.jsonl`` record.

        Raises
        ------
        ApiTypeError, ApiValueError
            ``record`` is not a mapping, or not a ``truth.jsonl`` record.
        """
        args = _Arguments("FrameTruth.from_record")
        args.instance("record", record, Mapping, "a truth.jsonl record (a dict)")
        missing = [key for key in _TRUTH_KEYS if key not in record]
        if missing:
            raise args.error("record", f"{missing[0]}: missing (a truth.jsonl record has {', '.join(_TRUTH_KEYS)})")
        try:
            rows, centre = record.get("led_rows"), record.get("led_centre_px")
            return cls(int(record["frame"]), float(record["start_s"]), float(record["row_time_s"]),
                       float(record["exposure_s"]), tuple(rows) if rows else None,
                       tuple(SduTruth(**sdu) for sdu in record["sdus"]),
                       None if centre is None else (float(centre[0]), float(centre[1])))
        except (TypeError, ValueError, OverflowError) as exc:  # a field of the wrong type or shape
            raise args.error("record", f"not a truth.jsonl record ({clip(str(exc))})") from None

    def _figures(self):
        return f"frame {self.frame}", [("start", quantity(self.start_s, "s")), *_sdu_figures(self)]

    def to_record(self) -> dict:
        """The ``truth.jsonl`` record."""
        record = {"frame": self.frame, "start_s": self.start_s, "row_time_s": self.row_time_s,
                  "exposure_s": self.exposure_s, "led_rows": list(self.led_rows) if self.led_rows else None,
                  "sdus": [{f.name: getattr(sdu, f.name) for f in fields(SduTruth)} for sdu in self.sdus]}
        if self.led_centre_px is not None:
            record["led_centre_px"] = list(self.led_centre_px)
        return record


class Truth(Shown, Sequence):
    """The truth of a run's frames, in frame order, with the scene they came from.

    Parameters
    ----------
    frames : sequence of FrameTruth
    scene : Scene
    """

    def __init__(self, frames: Sequence[FrameTruth], scene: "Scene"):
        args = _Arguments("Truth")
        self._frames = tuple(args.iterable("frames", frames, "a sequence of FrameTruth"))
        for number, frame in enumerate(self._frames):
            args.instance(f"frames[{number}]", frame, FrameTruth, "a FrameTruth")
        self.scene = _scene_object(args, scene)

    def __getitem__(self, index):
        return self._frames[index]

    def __len__(self) -> int:
        return len(self._frames)

    def _figures(self):
        frames = self._frames
        span = f" ({frames[0].frame}..{frames[-1].frame})" if frames else ""
        emitted = {sdu.tx for frame in frames for sdu in frame.sdus}
        visible = {sdu.tx for frame in frames for sdu in frame.sdus if sdu.fully_visible}
        return repr(self.scene.name), [("frames", f"{len(frames)}{span}"), ("PHY-SDUs", len(emitted)),
                                       ("fully visible", len(visible))]

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


@dataclass(frozen=True, repr=False)
class Frame(Shown):
    """A rendered frame: its index, image (uint8 or uint16 array) and truth."""

    index: int
    image: np.ndarray
    truth: FrameTruth

    def _figures(self):
        height, width, *channels = self.image.shape
        size = "x".join(str(n) for n in (width, height, *channels))
        return str(self.index), [("image", f"{size} {self.image.dtype}"), *_sdu_figures(self.truth)]


class Frames(Shown):
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
        args = _Arguments("Frames")
        self.scene = _scene_object(args, scene)
        self.n_frames, self.start = _frame_span(args, n_frames, start)
        self._truth: dict[int, FrameTruth] = {}
        self._pipeline: Any = None

    def __len__(self) -> int:
        return self.n_frames

    def _figures(self):
        camera = self.scene.camera
        count = f"{self.n_frames}" + (f" (from frame {self.start})" if self.start else "")
        return repr(self.scene.name), [("count", count), ("size", f"{camera.width_px}x{camera.height_px} {camera.output}"),
                                       ("seed", self.scene.seed)]

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


def _scene_object(args: _Arguments, scene) -> "Scene":
    """``scene`` if it is a loaded Scene (a class's argument, which loads nothing)."""
    from rollsim.scene.model import Scene

    return args.instance("scene", scene, Scene, "a Scene (from rollsim.load_scene)")


def _frame_span(args: _Arguments, n_frames, start) -> tuple[int, int]:
    """``n_frames`` and ``start`` checked: counts whose frame indices stay exact as floats (frame times)."""
    n_frames = args.integer("n_frames", n_frames, 0, MAX_FRAMES)
    return n_frames, args.integer("start", start, 0, MAX_COUNT - n_frames)


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
    args = _Arguments("render")
    args.scene("scene", scene)
    n_frames = args.integer("n_frames", n_frames, 0, MAX_FRAMES, optional=True)
    _frame_span(args, n_frames or 0, start)
    seed = args.seed("seed", seed, optional=True)
    loaded = _load(args, "scene", scene, [] if seed is None else [f"seed={seed}"])
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
        :class:`rollsim.stages.decode.DecodeSettings` (``phy``, ``clock_hz``,
        ``row_time_s``); a record is a :class:`decoder.DecodedPhySdu` or a
        dict with the fields of ``decoded.jsonl`` (checked against its
        schema, :mod:`rollsim.stages.records`). Default: rollsim's.

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
    from decoder.io import FrameError
    from rollsim.stages.decode import settings_from_scene
    from rollsim.stages.records import scene_run_identifier

    args = _Arguments("decode")
    args.iterable("frames", frames, "Frames (from rollsim.render), or an iterable of Frame or of image arrays")
    args.callable("decoder", decoder, "a callable decoder(image, settings) or None")
    chosen = scene if scene is not None else getattr(frames, "scene", None)
    if chosen is None:
        raise args.error("scene", "give scene= for frames that are arrays (the link and camera the decoder is told of)")
    settings = settings_from_scene(_load(args, "scene", chosen))
    run = decoder if decoder is not None else rollsim_decoder
    # Records of rendered frames name their render, as rollsim decode's do.
    run_id = scene_run_identifier(frames.scene) if isinstance(frames, Frames) else None
    records: list[dict] = []
    for number, item in enumerate(frames):
        index, image = _frame_image(args, number, item)
        try:
            found = run(image, settings)
        except FrameError as exc:  # the decoder's own check of the image (rows, channels, NaN)
            raise args.error(f"frames[{number}]", str(exc)) from None
        records.extend(_decoded(args, index, found, run_id))
    return records


def _frame_image(args: _Arguments, number: int, item) -> tuple[int, np.ndarray]:
    """The index and image of item ``number`` of ``frames``: a Frame, or an array numbered ``number``."""
    if isinstance(item, Frame):
        return item.index, item.image
    return number, _image_array(args, f"frames[{number}]", item)


def _image_array(args: _Arguments, name: str, item) -> np.ndarray:
    """Argument ``name`` as an image array (2-D gray or 3-D colour, of numbers)."""
    expected = "a Frame or an image array (2-D gray or 3-D colour, of numbers)"
    try:
        image = np.asarray(item)
    except (TypeError, ValueError):  # a ragged list
        raise args.refuse(name, expected, item, ApiValueError) from None
    if image.dtype.kind not in "buif":
        raise args.refuse(name, expected, item)
    if image.ndim not in (2, 3):
        raise args.refuse(name, expected, item, ApiValueError)
    return image


def _decoded(args: _Arguments, index: int, found, run_id: Optional[str] = None) -> list[dict]:
    """A decoder's finds in frame ``index`` as ``decoded.jsonl`` records, each checked against the schema."""
    from rollsim.stages.records import as_decoded_record

    expected = "decoder(image, settings) to return an iterable of records"
    if isinstance(found, (str, bytes, Mapping)) or not isinstance(found, Iterable):
        raise args.error("decoder", f"expected {expected}, got {short_repr(found)} (frame {index})", ApiTypeError)
    try:
        return [as_decoded_record(record, index, run_id) for record in found]
    except RollsimError as exc:  # a record off the schema: the decoder's fault, named so
        raise args.error("decoder", str(exc)) from None


# --------------------------------------------------------------------- show


class AnnotatedFrame:
    """A frame drawn with its truth's PHY-SDUs by outcome and the rows a decoder read (:func:`show`).

    A notebook shows it as an image (``_repr_png_``); ``image`` is the RGB
    array, and :meth:`save` writes it as a PNG.

    Attributes
    ----------
    image : ndarray, uint8, shape (H, W, 3)
        RGB: the frame, then the truth's column and the decoder's, and a legend.
    index : int or None
        The frame's number, where known.
    """

    def __init__(self, image: np.ndarray, index: Optional[int]):
        self.image = image
        self.index = index

    def __repr__(self) -> str:
        height, width = self.image.shape[:2]
        which = "" if self.index is None else f" of frame {self.index}"
        return f"<AnnotatedFrame{which}: {width}x{height} px>"

    def _repr_png_(self) -> bytes:
        from rollsim.report.annotate import png_bytes

        return png_bytes(self.image)

    def save(self, path: Union[str, Path], force: bool = False) -> Path:
        """Write the image as a PNG at ``path`` (atomically; an existing file only with ``force``)."""
        from rollsim.plumbing.outputs import write_files

        args = _Arguments("AnnotatedFrame.save")
        target = Path(args.path("path", path))
        try:
            write_files({target: self._repr_png_()}, force=args.flag("force", force))
        except RollsimError as exc:
            raise args.error("path", str(exc)) from None
        return target


def show(frame: Union[Frame, np.ndarray], truth: Union[FrameTruth, Mapping, None] = None,
         decoded: Optional[Sequence[Mapping]] = None) -> AnnotatedFrame:
    """A frame drawn with its LED's rows, its truth's PHY-SDUs by outcome and the rows a decoder read.

    Beside the frame, a column of the truth's PHY-SDUs, each coloured by its
    outcome in this frame (``ok`` green, ``undetected_error`` red,
    ``corrupted`` orange, ``missed`` blue, ``not_visible`` grey), and a
    column of the decoded records, each coloured by its verdict (magenta:
    ``false``, a decode of no PHY-SDU); ``rollsim inspect`` draws the same
    from a run directory (:mod:`rollsim.report.annotate`).

    Parameters
    ----------
    frame : Frame or ndarray
        A rendered :class:`Frame` (its truth is used when ``truth`` is not
        given), or an image: grey (H, W) or RGB (H, W, 3), 8- or 16-bit.
    truth : FrameTruth or mapping, optional
        The frame's truth (a ``truth.jsonl`` record).
    decoded : sequence of mapping, optional
        Decoded records (``decoded.jsonl``'s, e.g. from :func:`decode`);
        where the frame's number is known, only its own are drawn.

    Returns
    -------
    AnnotatedFrame

    Examples
    --------
    >>> import rollsim as rs
    >>> frames = rs.render("paper-geometric", n_frames=1).materialise()
    >>> rs.show(frames[0], decoded=rs.decode(frames, scene="paper-geometric"))  # doctest: +ELLIPSIS
    <AnnotatedFrame of frame 0: ...x... px>
    """
    from rollsim.report.annotate import annotate

    args = _Arguments("show")
    if isinstance(frame, Frame):
        image, index = frame.image, frame.index
        truth = frame.truth if truth is None else truth
    else:
        image, index = _image_array(args, "frame", frame), None
    if isinstance(truth, FrameTruth):
        record: Optional[dict] = truth.to_record()
    elif truth is None:
        record = None
    else:
        args.instance("truth", truth, Mapping, "a FrameTruth or a truth.jsonl record (dict)")
        try:
            record = FrameTruth.from_record(truth).to_record()
        except ApiArgumentError as exc:  # named as this call's argument
            raise args.error("truth", str(exc).split(": record: ", 1)[-1]) from None
    if record is not None:
        index = int(record["frame"]) if index is None else index
    records = _decoded_records(args, decoded) if decoded is not None else []
    if index is not None:
        records = [r for r in records if r["frame"] == index]
    try:
        drawn = annotate(image, record, records)
    except ValueError as exc:
        raise args.error("frame", str(exc)) from None
    return AnnotatedFrame(drawn, index)


# ----------------------------------------------------------------- evaluate


class Result(Shown):
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
        from rollsim.stages.evaluate import Evaluation

        args = _Arguments("Result")
        args.instance("evaluation", evaluation, Evaluation, "an Evaluation (from rollsim.stages.evaluate.evaluate)")
        args.instance("truth", truth, Truth, "a Truth (from Frames.truth)")
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

    def _figures(self):
        counts = self.summary["counts"]
        figures: list[tuple[str, object]] = [("PHY-SDUs emitted", self.summary["emissions"])]
        figures += [(name.replace("_", " "), count) for name, count in counts.items()]
        message = self.summary.get("message")
        if message is not None:
            goodput = quantity(message["goodput_bps"], "bit/s")
            figures.append(("goodput", goodput if message["decodable"] else f"{goodput} (message not decodable)"))
        return repr(self.scene.name), figures

    def trace(self):
        """The success trace in emission order, with times and scene (:class:`rollsim.calibrate.Trace`)."""
        from rollsim.calibrate import Trace

        return Trace.from_outcomes(self.outcomes, self.truth, self.scene, "<rollsim.evaluate>")

    def to_dataframe(self):
        """The outcomes as a table (needs pandas)."""
        import pandas as pd

        from rollsim.stages.evaluate import OUTCOME_COLUMNS

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
    from rollsim.stages.evaluate import evaluate as run
    from rollsim.transmitter import transmitter_from_scene

    args = _Arguments("evaluate")
    args.instance("truth", truth, (Truth, Frames), "a Truth or Frames (from rollsim.render)")
    records = _decoded_records(args, decoded)
    if isinstance(truth, Frames):
        truth = truth.truth
    return Result(run(truth.to_records(), records, transmitter_from_scene(truth.scene)), truth)


def _decoded_records(args: _Arguments, decoded) -> list[dict]:
    """``decoded`` as ``decoded.jsonl`` records, each checked against the schema (as ``rollsim evaluate`` does)."""
    from rollsim.stages.records import record_error

    records = []
    for number, item in enumerate(args.iterable("decoded", decoded, "a sequence of decoded.jsonl records (dicts)")):
        record = dict(args.instance(f"decoded[{number}]", item, Mapping, "a decoded.jsonl record (a dict)"))
        problem = record_error(record)
        if problem is not None:
            raise args.error(f"decoded[{number}]", problem)
        records.append(record)
    return records


# ---------------------------------------------------------------- calibrate


@dataclass(frozen=True, repr=False)
class MmbpModel(Shown):
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

    def __post_init__(self):
        from rollsim.calibrate.mmbp import MmbpFit

        args = _Arguments("MmbpModel")
        args.instance("fit", self.fit, MmbpFit, "an MmbpFit (from rollsim.calibrate.fit_mmbp)")
        # Frozen: the checked count replaces a numpy integer through object's setter.
        object.__setattr__(self, "n_packets", args.integer("n_packets", self.n_packets, 1))

    @property
    def M(self) -> int:
        return self.fit.M

    @property
    def N(self) -> int:
        return self.fit.N

    @property
    def p_e(self) -> float:
        return self.fit.p_e

    def _figures(self):
        from rollsim.calibrate.mmbp import p_e_text

        return "", [("M", self.M), ("N", self.N), ("p_e", p_e_text(self.fit.as_dict()).removeprefix("p_e = ")),
                    ("N_p", self.n_packets)]

    def p_message(self, r: int, strategy: str = "rp", n_packets: Optional[int] = None) -> float:
        """Probability that one message round delivers every PHY-SDU (exact, log space).

        Parameters
        ----------
        r : int
            Repeats.
        strategy : {"rp", "rs"}
        n_packets : int, optional
            Default :attr:`n_packets`.

        Raises
        ------
        ApiTypeError, ApiValueError
            An argument of the wrong type or value, naming it.
        """
        from rollsim.channel.analytic import mmbp_p_message

        args = _Arguments("MmbpModel.p_message")
        r = args.integer("r", r, 1)
        strategy = args.choice("strategy", strategy, ("rp", "rs"))
        n = self.n_packets if n_packets is None else args.integer("n_packets", n_packets, 1)
        return float(mmbp_p_message(self.M, self.N, r, self.p_e, n, strategy))


@dataclass(frozen=True, repr=False)
class Calibration(Shown):
    """The channel models fitted to a run (``rollsim calibrate``).

    Attributes
    ----------
    mmbp : MmbpModel
    ge : rollsim.calibrate.ge.GeFit
    report : dict
        Everything ``calibration.json`` holds: criteria, held-out
        likelihoods, the position model, run lengths, whole-message curves,
        goodput predicted against replayed, the physics' prediction.
    """

    mmbp: MmbpModel
    ge: Any
    report: dict

    def _figures(self):
        ge, position = self.ge, self.report.get("position")
        steps = [("position steps", position["segments"])] if position else []
        selected = self.report.get("selected_by_heldout")
        return "", [*self.mmbp._figures()[1], ("GE p", ge.p), ("GE q", ge.q), ("GE p_e", ge.p_e), *steps,
                    ("selected by BIC", self.report["selected_by_bic"]),
                    *([("by held-out likelihood", selected)] if selected else [])]


def calibrate(result: Result, n_packets: Optional[int] = None, seed: int = 1) -> Calibration:
    """Fit the MMBP, Gilbert-Elliott and position models to a run's outcomes.

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

    args = _Arguments("calibrate")
    args.instance("result", result, Result, "a Result (from rollsim.evaluate)")
    n_packets = args.integer("n_packets", n_packets, 1, optional=True)
    seed = args.seed("seed", seed)
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
    from rollsim.channel.scene_channel import CHANNEL_KINDS, scene_relaxations, simulate_scene

    args = _Arguments("simulate")
    args.scene("scene", scene)
    channel = args.choice("channel", channel, CHANNEL_KINDS)
    runs = args.integer("runs", runs, 1)
    seed = args.seed("seed", seed, optional=True)
    workers = args.integer("workers", workers, 1, optional=True)
    loaded = _load(args, "scene", scene, relax=scene_relaxations(channel))
    return simulate_scene(loaded, channel, runs=runs, seed=seed, workers=workers)


# -------------------------------------------------------------------- sweep

# sweep's keyword options that are counts (see rollsim.sweeps.sweep).
_SWEEP_COUNTS = ("runs", "frames", "max_emissions")
# The most local Dask workers a sweep starts, as rollsim sweep --workers.
MAX_SWEEP_WORKERS = 1024


def _sweep_options(args: _Arguments, options: Mapping[str, Any]) -> dict:
    """The ``**options`` of :func:`sweep` checked: known names, each of its type."""
    from rollsim.sweeps.spec import CHANNELS, DEFAULTS

    known = (*DEFAULTS, "seed")
    checked = {}
    for name, value in options.items():
        if name not in known:
            raise args.error(name, f"not an argument of sweep (its options: {', '.join(known)})", ApiTypeError)
        if value is None:
            continue
        if name in _SWEEP_COUNTS:
            checked[name] = args.integer(name, value, 1)
        elif name == "seed":
            checked[name] = args.seed(name, value)
        elif name == "channel":
            checked[name] = args.choice(name, value, CHANNELS)
        else:
            checked[name] = args.flag(name, value)
    return checked


def _axes(args: _Arguments, name: str, value) -> Optional[dict]:
    """``grid`` or ``zip``: ``{key: values}``, values as text (``"5:40:5"``) or a list."""
    if value is None:
        return None
    axes = args.instance(name, value, Mapping, "a mapping of scene keys to values, e.g. {'link.distance_cm': [5, 10]}")
    for key, values in axes.items():
        args.instance(f"{name} key", key, str, "a scene key (str), e.g. 'link.distance_cm'")
        args.instance(f"{name}[{clip(repr(key), 40)}]", values, (str, list, tuple, np.ndarray),
                      "values as text ('5:40:5', '5,10') or a list")
    return dict(axes)


def sweep(scene: Union[str, Path, "Scene"], grid: Optional[Mapping[str, Any]] = None, stage: str = "analytic", *,
          zip: Optional[Mapping[str, Any]] = None, overrides=(), out=None, client=None,
          workers: Optional[int] = None, scheduler: Optional[str] = None, connect_timeout_s: Optional[float] = None,
          resume: bool = False, force: bool = False, **options):
    """Run a sweep of ``scene`` over ``grid`` on Dask; the results as a table.

    The arguments are checked here, before any cluster starts; the sweep is
    :func:`rollsim.sweeps.sweep`'s, which documents every parameter.

    Parameters
    ----------
    scene : str, Path or Scene
        See :func:`load_scene`.
    grid, zip : mapping, optional
        ``{key: values}``, each key's values as text (``"5:40:5"``) or a list.
    stage : {"analytic", "simulate", "run", "envelope"}
    overrides : mapping or iterable of str
        ``{"link.distance_cm": 10}`` or ``["link.distance_cm=10"]``.
    out : str or Path, optional
        Default a new temporary directory (kept when the sweep finishes,
        removed when it fails).
    client, workers, scheduler, connect_timeout_s, resume, force, **options
        As for :func:`rollsim.sweeps.sweep`.

    Returns
    -------
    pandas.DataFrame or Path

    Examples
    --------
    >>> import rollsim as rs
    >>> table = rs.sweep("paper-default", grid={"link.distance_cm": [5, 10]}, workers=1)  # doctest: +SKIP
    >>> rs.sweep("paper-default", grid={"link.distance_cm": [5, 10]}, stage="fast")
    Traceback (most recent call last):
    ...
    rollsim.errors.ApiValueError: rollsim.sweep: stage: expected one of 'analytic', 'simulate', 'run', 'envelope', got 'fast'
    """
    from rollsim.sweeps import sweep as run
    from rollsim.sweeps.scheduler import MAX_CONNECT_TIMEOUT_S
    from rollsim.sweeps.spec import STAGES

    args = _Arguments("sweep")
    checked = {"grid": _axes(args, "grid", grid), "stage": args.choice("stage", stage, STAGES),
               "zip": _axes(args, "zip", zip), "overrides": args.texts("overrides", overrides),
               "out": None if out is None else args.path("out", out),
               "workers": args.integer("workers", workers, 1, MAX_SWEEP_WORKERS, optional=True),
               "scheduler": None if scheduler is None else args.instance("scheduler", scheduler, str, "an address (str)"),
               "connect_timeout_s": args.positive("connect_timeout_s", connect_timeout_s, optional=True,
                                                  at_most=MAX_CONNECT_TIMEOUT_S),
               "resume": args.flag("resume", resume), "force": args.flag("force", force),
               **_sweep_options(args, options)}
    # rollsim.sweeps.sweep is annotated as taking a Scene; it takes a name or file too.
    return run(cast(Any, args.scene("scene", scene)), client=client, **checked)
