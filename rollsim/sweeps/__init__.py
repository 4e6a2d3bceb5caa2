"""Sweeps: one scene, many cells, on Dask; a table, a report, and resume.

A sweep varies scene keys over a grid (:mod:`rollsim.sweeps.grid`), checks
every cell before anything runs (:mod:`rollsim.sweeps.spec`), computes each
cell's stage (:mod:`rollsim.sweeps.stages`) on a Dask cluster
(:mod:`rollsim.sweeps.engine`), commits each finished cell to the output
directory's journal (:mod:`rollsim.sweeps.journal`), and at the end writes
the table (:mod:`rollsim.sweeps.table`) and the report
(:mod:`rollsim.sweeps.report`).
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Optional, Union, cast

from rollsim.sweeps.grid import Axis, Cell, parse_values
from rollsim.sweeps.spec import DEFAULTS, STAGES, SweepSpec, spec_from_arguments, validate_cells
from rollsim.plumbing.text_tables import Shown

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

__all__ = ["Axis", "Cell", "STAGES", "SweepResult", "SweepSpec", "parse_values", "run_sweep", "spec_from_arguments",
           "sweep", "validate_cells"]


@dataclass(repr=False)
class SweepResult(Shown):
    """What a sweep produced.

    Attributes
    ----------
    out_dir : Path
    rows : list of dict
        One per cell, in grid order (:mod:`rollsim.sweeps.table`).
    columns : list of str
    computed : int
        Cells computed by this call (the others were committed before: ``--resume``).
    failed : int
        Cells whose status is ``error``.
    stage : str
        The stage each cell ran (``analytic``, ``simulate``, ...).
    """

    out_dir: Path
    rows: list
    columns: list
    computed: int
    failed: int
    stage: str = ""

    def _figures(self):
        from rollsim.sweeps.table import STAGE_COLUMNS, TRAILING

        figures = [("cells", f"{len(self.rows)} ({self.computed} computed now)"), ("ok", len(self.rows) - self.failed),
                   ("failed", self.failed), ("in", self.out_dir)]
        if self.stage not in STAGE_COLUMNS:
            return "", figures
        # The table's columns: cell, the swept keys, the stage's figures, the trailing ones.
        swept = self.columns[1 : len(self.columns) - len(STAGE_COLUMNS[self.stage]) - len(TRAILING)]
        return f"{self.stage} stage", [("over", ", ".join(swept) or "no key"), *figures]

    def to_dataframe(self):
        """The table as a pandas DataFrame (None where pandas is not installed)."""
        from rollsim.sweeps.table import to_dataframe

        return to_dataframe(self.rows, self.columns)


def _error_rows(batch: list, exc: BaseException) -> list[dict]:
    """Rows of the cells of a task that failed as a whole (its worker died)."""
    reason = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
    return [{"cell": index, "cell_id": cell_id, "seed": seed, "status": "error", "seconds": None,
             "error": f"the task running this cell failed ({reason})"} for index, cell_id, seed, _ in batch]


def run_sweep(
    spec: SweepSpec,
    out_dir: Path,
    *,
    workers: Optional[int] = None,
    scheduler: Optional[str] = None,
    connect_timeout_s: Optional[float] = None,
    client=None,
    resume: bool = False,
    force: bool = False,
    progress: Optional[Callable[[int], None]] = None,
    on_start: Optional[Callable[[int, int, object], None]] = None,
) -> SweepResult:
    """Run a sweep into ``out_dir`` and write its table and report.

    Parameters
    ----------
    spec : SweepSpec
    out_dir : Path
    workers : int, optional
        Size of the local Dask cluster (default: one per core).
    scheduler : str, optional
        Address of a running Dask scheduler to use instead.
    connect_timeout_s : float, optional
        Deadline of the connection to ``scheduler``, in seconds (default
        10, or ``$ROLLSIM_CONNECT_TIMEOUT``). A peer that greets as Dask
        does and then falls silent is given up at the deadline, but Dask's
        client offers no way to cancel its handshake: its thread and socket
        stay until the process ends.
    client : dask.distributed.Client, optional
        A client to use instead of either.
    resume : bool
        Continue the sweep already in ``out_dir``: only cells not committed
        (or that failed) are computed.
    force : bool
        Replace a previous rollsim result in ``out_dir``.
    progress : callable, optional
        ``progress(n)`` after each finished batch of ``n`` cells.
    on_start : callable, optional
        ``on_start(to_compute, total, client)`` once the cluster is up.

    Raises
    ------
    RollsimError
        A bad cell (before anything runs), an unusable ``out_dir``, an
        unreachable scheduler.
    """
    from rollsim.scene.bundled import resolve_scene_path
    from rollsim.sweeps.engine import BackgroundStart, DaskEngine
    from rollsim.sweeps.journal import SweepDirectory, scene_digest

    # The cluster starts while the cells are validated: starting workers
    # runs no cell, and it takes as long as validating thousands of them.
    # A mistake every cell shares (an unknown key) stops the sweep first.
    quick = validate_cells(spec, quick=True)
    record = {**spec.as_dict(quick.seed), "scene_sha256": scene_digest(quick.base)}
    scene_path = resolve_scene_path(spec.scene) if spec.base is None else None
    inputs = [scene_path] if scene_path is not None and scene_path.exists() else []
    SweepDirectory.check(Path(out_dir), record, resume=resume, force=force, inputs=inputs)
    if spec.stage == "run" and spec.keep_frames:
        _check_kept_frames_disk(spec, quick, Path(out_dir))
    engine = DaskEngine(workers, scheduler, spec.stage, connect_timeout_s) if client is None else None
    starting = BackgroundStart(engine) if engine is not None else None
    try:
        resolved = validate_cells(spec)
        # The output directory only once the cluster answers: an
        # unreachable scheduler leaves nothing behind.
        active = client if starting is None else starting.result()
    except BaseException:
        if starting is not None:
            starting.abandon()
        raise
    try:
        directory = SweepDirectory.open(Path(out_dir), record, resume=resume, force=force, inputs=inputs)
        try:
            done = directory.committed()
            todo = [cell for cell in resolved.cells if done.get(cell.id, {}).get("status") != "ok"]
            if todo:
                _compute(active, spec, resolved, todo, directory, progress, on_start)
            # The workers draw the plots while this process writes the table.
            return _finish(directory, resolved, spec, computed=len(todo), submit=active.submit)
        finally:
            directory.close()
    except BaseException:
        if engine is not None:
            engine.close(stopping=True)
        raise
    finally:
        if engine is not None:
            engine.close()  # after the above, nothing is left to close


def _check_kept_frames_disk(spec: SweepSpec, resolved, out_dir: Path) -> None:
    """Refuse ``--keep-frames`` whose frames, every cell's scene's, would not fit the disk budget."""
    from rollsim.plumbing.budget import check_disk
    from rollsim.render.writer import frame_disk_bytes
    from rollsim.scene import scene_from_dict

    # Built again here (validation keeps no scene): milliseconds a cell,
    # against the seconds a cell of the run stage renders for.
    per_frame = [frame_disk_bytes(scene_from_dict(resolved.base, spec.scene, spec.overrides, resolved.cell_values(cell)))
                 for cell in resolved.cells]
    check_disk(f"--keep-frames: {len(per_frame)} cells x {spec.frames} frames", sum(per_frame) * spec.frames, out_dir)


def _compute(client, spec: SweepSpec, resolved, todo: list, directory, progress, on_start) -> None:
    """Run the cells of ``todo`` on the cluster, committing each batch as it finishes."""
    from rollsim.sweeps.engine import batch_size, run_tasks, worker_count
    from rollsim.sweeps.stages import compute_cells

    frames_root = None
    if spec.stage == "run" and spec.keep_frames:
        frames_root = directory.path / "frames"
        frames_root.mkdir(exist_ok=True)
    if on_start is not None:
        on_start(len(todo), len(resolved.cells), client)
    size = batch_size(spec.stage, len(todo), worker_count(client))
    payload = [(c.index, c.id, c.seed(resolved.seed), resolved.cell_values(c)) for c in todo]
    batches = [payload[k : k + size] for k in range(0, len(payload), size)]
    args = (spec.stage, resolved.base, resolved.source, list(spec.overrides), spec.stage_options(),
            None if frames_root is None else str(frames_root))
    tasks = run_tasks(client, compute_cells, batches, *args)
    if spec.stage == "analytic":
        # Its cells take seconds in all: the writers' second of imports is
        # worth overlapping with them. Longer stages would only lose a
        # core's second to it.
        _warm_up_writers()
    try:
        for batch, result in tasks:
            rows = _error_rows(batch, result) if isinstance(result, BaseException) else cast(list, result)
            directory.append(rows)
            if progress is not None:
                progress(len(rows))
    finally:
        # Cancel what is left while the client still runs: left to the
        # garbage collector (a signal's traceback holds the generator), the
        # cancel would meet a closed event loop and print its traceback.
        tasks.close()


def _warm_up_writers() -> None:
    """Import what the table and the report need (a second of imports)."""
    import matplotlib.figure  # noqa: F401
    import pyarrow.parquet  # noqa: F401


def _finish(directory, resolved, spec: SweepSpec, computed: int, submit=None) -> SweepResult:
    """Write the table (Parquet, CSV) and the report, all together.

    ``submit`` (a Dask client's) draws the plots on the workers meanwhile.
    """
    from rollsim.plumbing.outputs import write_files
    from rollsim.sweeps.report import report_files, start_plots
    from rollsim.sweeps.table import columns_of, csv_text, parquet_bytes, table_rows

    keys = spec.swept_keys()
    columns = columns_of(spec.stage, keys)
    rows = table_rows(list(directory.committed().values()), resolved.cells, spec.stage, keys)
    axes = [axis.keys[0] for axis in spec.axes()]
    plots = start_plots(rows, axes, spec.stage, submit)
    failed = sum(1 for row in rows if row["status"] != "ok")
    header = [f"# rollsim sweep: {spec.stage} stage of {spec.scene}", "",
              f"{len(rows)} cells over {', '.join(keys)}; {len(rows) - failed} ok, {failed} failed "
              f"(seed {resolved.seed}). The table: results.parquet and results.csv; the sweep: sweep.yaml."]
    files = {directory.path / "results.parquet": parquet_bytes(rows, columns),
             directory.path / "results.csv": csv_text(rows, columns)}
    files.update(report_files(plots, rows, axes, header, directory.path))
    (directory.path / "plots").mkdir(exist_ok=True)
    write_files(files, force=True)
    return SweepResult(directory.shown, rows, columns, computed, failed, spec.stage)


def sweep(scene: Union[str, Path, Scene], grid: Optional[dict] = None, stage: str = "analytic", *, zip: Optional[dict] = None,
          overrides=(), out=None, client=None, workers: Optional[int] = None, scheduler: Optional[str] = None,
          connect_timeout_s: Optional[float] = None, resume: bool = False, force: bool = False, **options):
    """Run a sweep from Python; the results as a table.

    Parameters
    ----------
    scene : str, Path or Scene
        A bundled scene name, a scene file, or a scene loaded with
        :func:`rollsim.load_scene`.
    grid : dict, optional
        ``{key: VALUES}``: each key's values as text (``"5:40:5"``) or a list.
    stage : {"analytic", "simulate", "run", "envelope"}
    zip : dict, optional
        Keys varied together.
    overrides : iterable of str
        ``KEY=VALUE`` overrides of the base scene.
    out : path, optional
        Output directory; default a new temporary directory (kept when
        the sweep finishes, removed when it fails).
    client : dask.distributed.Client, optional
        Run on this client's cluster.
    workers, scheduler, connect_timeout_s, resume, force
        As for :func:`run_sweep`.
    **options
        ``runs``, ``frames``, ``channel``, ``seed``, ``max_emissions``,
        ``keep_frames``.

    Returns
    -------
    pandas.DataFrame or Path
        The table (its ``attrs["sweep_dir"]`` names the directory), or the
        directory where pandas is not installed.

    Examples
    --------
    >>> import rollsim
    >>> table = rollsim.sweep("paper-default", grid={"link.distance_cm": "5,10"}, workers=1)  # doctest: +SKIP
    >>> list(table["M"])  # doctest: +SKIP
    [3, 2]
    """
    unknown = sorted(set(options) - set(DEFAULTS))
    if unknown:
        raise TypeError(f"rollsim.sweep: unknown option {unknown[0]!r}; expected any of {', '.join(DEFAULTS)}")
    source, base = _scene_source(scene)
    spec = spec_from_arguments(source, grid=grid or {}, zipped=zip or {}, overrides=list(overrides), stage=stage,
                               options=options, base=base)
    made = Path(tempfile.mkdtemp(prefix="rollsim-sweep-")) if out is None else None
    try:
        result = run_sweep(spec, Path(out) if made is None else made / "sweep", workers=workers, scheduler=scheduler,
                           connect_timeout_s=connect_timeout_s, client=client, resume=resume, force=force)
    except BaseException:
        if made is not None:  # made by this call a moment ago: nothing of the user's is in it
            shutil.rmtree(made, ignore_errors=True)
        raise
    table = result.to_dataframe()
    if table is None:
        return result.out_dir
    table.attrs["sweep_dir"] = str(result.out_dir)
    return table


def _scene_source(scene) -> tuple[str, Optional[dict]]:
    """How a sweep names ``scene``, and its data when it is a :class:`Scene` held in memory."""
    from rollsim.scene import Scene
    from rollsim.scene.loader import scene_to_dict

    if isinstance(scene, Scene):
        return scene.name, scene_to_dict(scene)
    return str(scene), None
