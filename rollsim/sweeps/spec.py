"""What a sweep is: a scene, its swept keys, a stage and the stage's options.

A sweep comes from command-line flags, from a sweep file, or from both (flags
override the file)::

    scene: paper-default            # a bundled name, or a path relative to this file
    set: [camera.exposure_us=50]    # overrides of the base scene (optional)
    grid:
      link.distance_cm: 5:40:5      # VALUES text, or a YAML list
      link.strategy: [rp, rs]
    zip:                            # keys varied together (optional)
      link.clock_hz: 4000,8000
      link.payload_bits: 19,38
    stage: simulate                 # analytic | simulate | run | envelope
    runs: 1000                      # simulate: runs per cell
    channel: mmbp                   # simulate: mmbp | timed | camcomsim
    frames: 100                     # run, envelope: frames per cell
    seed: 7                         # default: the scene's seed
    keep_frames: false              # run: also write each cell's PNG frames

Every cell is validated (:func:`validate_cells`) before anything runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Optional

from rollsim.version import __version__
from rollsim.errors import RollsimError, SceneError, clip
from rollsim.sweeps.grid import Axis, Cell, build_cells, grid_axis, zip_axis

STAGES = ("analytic", "simulate", "run", "envelope")
CHANNELS = ("mmbp", "timed", "camcomsim")
DEFAULTS: dict[str, Any] = {"runs": 1000, "frames": 100, "channel": "mmbp", "max_emissions": 50_000, "keep_frames": False}
_FILE_KEYS = {"scene", "set", "grid", "zip", "stage", "seed", *DEFAULTS}


@dataclass(frozen=True)
class SweepSpec:
    """A resolved sweep.

    Attributes
    ----------
    scene : str
        Bundled scene name or scene file path (or, with ``base``, how lines
        name the scene).
    base : mapping, optional
        The base scene's data, for a sweep of a scene held in memory (the
        Python API's :class:`rollsim.scene.model.Scene`); None reads ``scene``.
    overrides : tuple of str
        ``KEY=VALUE`` overrides of the base scene (``--set``).
    grid : tuple of (str, VALUES)
        Swept keys and their values (text or list), in order.
    zipped : tuple of (str, VALUES)
        Keys varied together.
    stage : {"analytic", "simulate", "run", "envelope"}
    seed : int or None
        Sweep seed; None means the base scene's.
    runs, frames, channel, max_emissions, keep_frames
        The stages' options (see the module docstring).
    """

    scene: str
    stage: str
    grid: tuple = ()
    zipped: tuple = ()
    overrides: tuple = ()
    seed: Optional[int] = None
    runs: int = DEFAULTS["runs"]
    frames: int = DEFAULTS["frames"]
    channel: str = DEFAULTS["channel"]
    max_emissions: int = DEFAULTS["max_emissions"]
    keep_frames: bool = DEFAULTS["keep_frames"]
    options_given: frozenset = field(default=frozenset(), compare=False)
    base: Optional[Mapping] = field(default=None, compare=False)

    def axes(self) -> list[Axis]:
        """The grid axes, then the zip axis."""
        axes = [grid_axis(key, values) for key, values in self.grid]
        if self.zipped:
            axes.append(zip_axis(dict(self.zipped)))
        return axes

    def cells(self) -> list[Cell]:
        return build_cells(self.axes())

    def swept_keys(self) -> list[str]:
        return [key for axis in self.axes() for key in axis.keys]

    def stage_options(self) -> dict:
        """The options the stage uses (what makes two sweeps' cells alike)."""
        if self.stage == "simulate":
            return {"runs": self.runs, "channel": self.channel, "max_emissions": self.max_emissions}
        if self.stage == "run":
            return {"frames": self.frames, "keep_frames": self.keep_frames}
        if self.stage == "envelope":
            return {"frames": self.frames}
        return {}

    def as_dict(self, sweep_seed: int) -> dict:
        """The resolved sweep, as ``sweep.yaml`` records it."""
        return {
            "rollsim": __version__,
            "scene": self.scene,
            "set": list(self.overrides),
            "grid": {key: _plain(values) for key, values in self.grid},
            "zip": {key: _plain(values) for key, values in self.zipped},
            "stage": self.stage,
            "seed": sweep_seed,
            **self.stage_options(),
        }


def _plain(values):
    return list(values) if isinstance(values, (list, tuple)) else values


def _check_stage(stage, where: str) -> str:
    if stage not in STAGES:
        raise RollsimError(f"{where}: stage = {clip(repr(stage), 40)}: must be one of {', '.join(STAGES)}")
    return stage


def _key_values(items, option: str) -> tuple:
    """``["KEY=VALUES", ...]`` (or a ``{key: values}`` mapping) as ``((key, values), ...)``."""
    if isinstance(items, dict):
        return tuple((str(key), values) for key, values in items.items())
    from rollsim.scene.loader import refuse_repeated_keys, split_key_value

    pairs = tuple(split_key_value(item, option, "KEY=VALUES, e.g. link.distance_cm=5:40:5") for item in items)
    refuse_repeated_keys((option, item) for item in items)
    return pairs


def read_sweep_file(path: Path) -> dict:
    """A sweep file's mapping, checked for unknown keys; its scene path made relative to the file."""
    from rollsim.scene import read_yaml

    data = read_yaml(path)
    unknown = sorted(set(data) - _FILE_KEYS)
    if unknown:
        import difflib

        close = difflib.get_close_matches(str(unknown[0]), sorted(_FILE_KEYS), n=1, cutoff=0.0)
        raise RollsimError(f"{path}: {clip(str(unknown[0]), 40)}: unknown key; did you mean {close[0]!r}?")
    if "scene" not in data:
        raise RollsimError(f"{path}: scene: required key is missing")
    for name in ("grid", "zip"):
        if not isinstance(data.get(name) or {}, dict):
            raise RollsimError(f"{path}: {name}: must be a mapping of KEY: VALUES")
    sets = data.get("set") or []
    if isinstance(sets, dict):
        sets = [f"{key}={value}" for key, value in sets.items()]
    if not isinstance(sets, list) or not all(isinstance(item, str) for item in sets):
        raise RollsimError(f"{path}: set: must be a list of KEY=VALUE or a mapping")
    data["set"] = sets
    scene = str(data["scene"])
    candidate = (path.parent / scene)
    if candidate.exists():
        data["scene"] = str(candidate)
    return data


def is_sweep_file(path: str) -> bool:
    """Whether ``path`` names a sweep file (a YAML mapping with ``scene`` and a ``grid`` or ``zip``)."""
    from rollsim.scene import read_yaml

    candidate = Path(path)
    if not candidate.is_file():
        return False
    try:
        data = read_yaml(candidate)
    except SceneError:
        return False
    return "scene" in data and ("grid" in data or "zip" in data)


def spec_from_arguments(source: str, *, grid=(), zipped=(), overrides=(), stage=None, options: Optional[dict] = None,
                        base: Optional[Mapping] = None) -> SweepSpec:
    """A sweep from ``SCENE`` or a sweep file, with flags over the file.

    Parameters
    ----------
    source : str
        A scene (bundled name or file), or a sweep file.
    grid, zipped : iterable of str, or dict
        ``KEY=VALUES`` of ``--grid`` and ``--zip`` (or ``{key: values}``);
        a grid key given here replaces the file's, and any ``--zip``
        replaces the file's zip.
    overrides : iterable of str
        ``--set`` items, after the file's ``set``.
    stage : str, optional
    options : dict, optional
        ``runs``, ``frames``, ``channel``, ``seed``, ``max_emissions``,
        ``keep_frames`` given on the command line (None values ignored).
    base : mapping, optional
        The base scene's data when the scene is held in memory; ``source``
        then only names it.
    """
    options = {k: v for k, v in (options or {}).items() if v is not None}
    file_data: dict = {}
    scene = source
    if base is None and is_sweep_file(source):
        file_data = read_sweep_file(Path(source))
        scene = file_data["scene"]
    grid_items = dict((k, v) for k, v in (file_data.get("grid") or {}).items())
    grid_items.update(_key_values(grid, "--grid"))
    zip_items = dict(_key_values(zipped, "--zip")) if zipped else dict((file_data.get("zip") or {}).items())
    stage = _check_stage(stage or file_data.get("stage") or "analytic", source)
    values = {name: file_data.get(name, default) for name, default in DEFAULTS.items()}
    values.update({k: v for k, v in options.items() if k in DEFAULTS})
    seed = options.get("seed", file_data.get("seed"))
    if values["channel"] not in CHANNELS:
        raise RollsimError(f"{source}: channel = {clip(repr(values['channel']), 40)}: must be one of {', '.join(CHANNELS)}")
    for name in ("runs", "frames", "max_emissions"):
        if not isinstance(values[name], int) or isinstance(values[name], bool) or values[name] < 1:
            raise RollsimError(f"{source}: {name} = {clip(repr(values[name]), 40)}: must be a positive integer")
    if seed is not None and (not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2**63):
        raise RollsimError(f"{source}: seed = {clip(repr(seed), 40)}: must be an integer in [0, 2**63)")
    return SweepSpec(
        scene=str(scene), stage=stage, grid=tuple(grid_items.items()), zipped=tuple(zip_items.items()),
        overrides=tuple(file_data.get("set", [])) + tuple(overrides), seed=seed,
        runs=values["runs"], frames=values["frames"], channel=values["channel"],
        max_emissions=values["max_emissions"], keep_frames=bool(values["keep_frames"]),
        options_given=frozenset(options), base=base,
    )


@dataclass(frozen=True)
class ResolvedSweep:
    """A validated sweep: its base scene data and every cell's overrides.

    Attributes
    ----------
    spec : SweepSpec
    base : dict
        The scene file's data (the worker validates each cell from it).
    source : str
        How error lines name the scene.
    seed : int
        The sweep seed.
    cells : list of Cell
    """

    spec: SweepSpec
    base: dict
    source: str
    seed: int
    cells: list

    def cell_values(self, cell: Cell) -> dict:
        """A cell's overrides after the base ``--set``: its values, its seed (and frames for ``run`` and ``envelope``)."""
        extra = {"frames": self.spec.frames} if self.spec.stage in ("run", "envelope") else {}
        return {**cell.values, "seed": cell.seed(self.seed), **extra}


def validate_cells(spec: SweepSpec, quick: bool = False) -> ResolvedSweep:
    """Validate every cell's scene before anything runs.

    Parameters
    ----------
    spec : SweepSpec
    quick : bool
        Only the first and last cells: what most mistakes (an unknown key, a
        malformed value) already show, in milliseconds.

    Raises
    ------
    RollsimError
        One line per distinct problem, naming the first cell that has it
        (``cell 3 (link.distance_cm=0.1): …``) and how many more share it.
    """
    from rollsim.scene import read_yaml, scene_from_dict
    from rollsim.scene.bundled import resolve_scene_path

    base = dict(spec.base) if spec.base is not None else read_yaml(resolve_scene_path(spec.scene))
    base_scene = scene_from_dict(base, spec.scene, spec.overrides)  # the base alone first: a clearer error
    seed = base_scene.seed if spec.seed is None else spec.seed
    resolved = ResolvedSweep(spec, base, spec.scene, seed, spec.cells())
    problems: dict[str, list[Cell]] = {}
    # Quick: the first and last cells (one, when the sweep has one).
    for cell in (resolved.cells[:1] + resolved.cells[1:][-1:]) if quick else resolved.cells:
        try:
            scene_from_dict(base, spec.scene, spec.overrides, resolved.cell_values(cell))
        except SceneError as exc:
            for line in exc.lines:
                problems.setdefault(line, []).append(cell)
    if problems:
        lines = []
        for line, cells in problems.items():
            more = f" (and {len(cells) - 1} more cells)" if len(cells) > 1 else ""
            lines.append(f"cell {cells[0].index} ({cells[0].describe()}){more}: {line}")
        raise RollsimError(lines)
    return resolved

