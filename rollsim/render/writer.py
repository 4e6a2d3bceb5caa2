"""Render a scene to disk: PNG frames (or one video file), truth.jsonl and scene.resolved.yaml.

Frames stream through a bounded window of work, so memory stays flat however
many frames are rendered. With several workers, each process builds the
pipeline once, then renders, PNG-encodes and writes whole chunks of frames
itself (only the small truth records travel back); truth lines are written
in frame order. Every random stream depends only on the seed and the frame
index, so the output is byte-identical for any number of workers. A video
(:class:`rollsim.video.VideoSettings`) is encoded here, in frame order, from
the images the workers send back.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable, Iterator, Optional

from rollsim.numerics.jit import numpy_only
from rollsim.version import __version__
from rollsim.plumbing.outputs import staged_directory
from rollsim.plumbing.parallel import chunked, default_workers, ordered_chunk_map
from rollsim.protocol.frames import FRAME_NAME  # the name decoders read back
from rollsim.render.pipeline import RenderPipeline, check_render_memory
from rollsim.render.png import encode_png
from rollsim.scene import scene_to_yaml

if TYPE_CHECKING:
    from rollsim.scene.model import Scene
    from rollsim.video import VideoSettings
    from rollsim.scene_sections import SceneSections

CHUNK_FRAMES = 4
# Bytes of a frame's samples per pixel, by output format. The PNG of a noisy
# frame holds 80-90 % of them (paper-default: 1.78 of 2.07 MB a frame), so
# the samples' size is an upper bound of the file's.
_SAMPLE_BYTES = {"gray8": 1, "raw16": 2, "rgb8": 3}
# A PNG's chunks and text (its metadata) and a truth line's frame fields,
# per frame; a truth line holds every PHY-SDU overlapping the frame, at
# about 230 bytes each (paper-default: 1.4 kB a line): 400 is a bound.
_FRAME_OVERHEAD_BYTES = 4096
_TRUTH_BYTES_PER_SDU = 400


@dataclass(frozen=True)
class RenderSummary:
    """What a render wrote."""

    out_dir: Path
    frames: int
    workers: int


def frame_text(scene: SceneSections, truth: dict) -> dict[str, str]:
    """A frame's metadata, as its PNG text chunks say it.

    The camera settings a decoder may use (exposure, ISO, row time, black
    level, gain at the set ISO, ADC bits, output format), the frame's index
    and start time, the seeds and the rollsim version. Numbers are written
    with ``repr``, so they read back exactly.
    """
    cam = scene.camera
    return {
        "Software": f"rollsim {__version__}",
        "rollsim_version": __version__,
        "scene": scene.name,
        "frame": str(truth["frame"]),
        "start_s": repr(truth["start_s"]),
        "exposure_us": repr(cam.exposure_us),
        "iso": repr(cam.iso),
        "row_time_us": repr(cam.row_time_s * 1e6),
        "black_level_dn": str(cam.black_level_dn),
        "gain_dn_per_e": repr(cam.gain_dn_per_e_at_iso),
        "adc_bits": str(cam.adc_bits),
        "output": cam.output,
        "seed": str(scene.seed),
        "identity_seed": str(scene.seed if cam.identity_seed is None else cam.identity_seed),
    }


_WORKER_PIPELINE: Optional[RenderPipeline] = None


# A video's rate control may overshoot its average bitrate this many times.
_BITRATE_MARGIN = 2.0


def frame_disk_bytes(scene: Scene, video: Optional[VideoSettings] = None) -> float:
    """An upper bound of the bytes one rendered frame takes on disk: its PNG (or its
    share of the video) and its truth line.

    A video at a set bitrate takes at most :data:`_BITRATE_MARGIN` times its
    share of it; at a constant rate factor it is bounded by the samples, as a PNG.
    """
    from rollsim.transmitter import phy_from_scene

    cam = scene.camera
    samples = float(cam.width_px * cam.height_px * _SAMPLE_BYTES.get(cam.output, 6))
    if video is not None and video.crf is None:
        from rollsim.video.settings import DEFAULT_BITRATE_BPS

        samples = min(samples, _BITRATE_MARGIN * (video.bitrate_bps or DEFAULT_BITRATE_BPS) / 8 * cam.frame_period_s)
    sdus = cam.frame_period_s * scene.link.clock_hz / max(1, phy_from_scene(scene).sdu_chips) + 2
    return samples + _FRAME_OVERHEAD_BYTES + _TRUTH_BYTES_PER_SDU * sdus


def check_render_disk(scene: Scene, n_frames: int, target: Path, what: str = "",
                      video: Optional[VideoSettings] = None) -> None:
    """Refuse ``n_frames`` of ``scene`` whose files would not fit the disk budget under ``target``.

    ``what`` names the option that asked for them, before the frame count.
    """
    from rollsim.plumbing.budget import check_disk

    cam = scene.camera
    check_disk(f"{what}{n_frames} frames of {cam.width_px} x {cam.height_px} {cam.output}",
               n_frames * frame_disk_bytes(scene, video), target)


def prepare_render(scene: Scene) -> None:
    """Build the render's pipeline of ``scene`` now (once: the render then uses it).

    Raises the scene's errors (an impossible scene, a frame over the memory
    budget) before anything is written. Forked workers inherit the pipeline:
    the same scene object, nothing to rebuild.
    """
    global _WORKER_PIPELINE
    if _WORKER_PIPELINE is None or _WORKER_PIPELINE.setup.scene is not scene:
        _WORKER_PIPELINE = RenderPipeline(scene)


def _init_worker(scene: Scene) -> None:
    prepare_render(scene)


def warm_up_render(pipeline: RenderPipeline) -> None:
    """Load the compiled kernels ``pipeline``'s frames run, and build the Poisson
    tables of its first frame's means: before worker processes fork and inherit them.

    numba keeps one machine code per pattern of a kernel's arguments (the
    chain's means given as a frame or as their parts, a step the scene does
    not take passed as None); only the scene's own stages say which the
    render will load. Running them on frame 0 here (a frame's time, its
    result dropped: every frame depends only on the scene, the seed and its
    index) loads those, where loading another pattern would leave each
    worker to load the render's on its first frame (about 0.15 s at 1080p).
    Nothing is run where the numpy twins render (:func:`is_short_render`,
    ``ROLLSIM_JIT=0`` or no numba).
    """
    from rollsim.numerics.jit import numba_module

    if numba_module() is not None:
        pipeline.run_stages(0)


def _render_chunk(indices: list[int], frames_dir: Path, decode: Optional[Callable] = None) -> list[tuple]:
    written = []
    assert _WORKER_PIPELINE is not None  # set by _init_worker in this process
    scene = _WORKER_PIPELINE.setup.scene
    for index in indices:
        frame = _WORKER_PIPELINE.render(index)
        png = encode_png(frame.image, frame_text(scene, frame.truth))
        path = frames_dir / FRAME_NAME.format(frame.index)
        path.write_bytes(png)
        written.append((frame.truth, None if decode is None else decode(frame.index, frame.image, str(path))))
    return written


def chunk_frames(scene: Scene) -> int:
    """Frames a worker renders at a time: :data:`CHUNK_FRAMES`, or one GOP of a scene with
    ``video_codec`` (chunks start on its key frames, so no GOP is coded twice)."""
    from rollsim.render.pipeline import gop_frames

    assert _WORKER_PIPELINE is not None and _WORKER_PIPELINE.setup.scene is scene  # built by _init_worker
    gop = gop_frames(_WORKER_PIPELINE.setup)
    return CHUNK_FRAMES if gop == 1 else gop


def _render_images(indices: list[int]) -> list[tuple]:
    """Render frames and hand back ``(truth record, image)`` (a video is encoded in the parent, in order)."""
    assert _WORKER_PIPELINE is not None  # set by _init_worker in this process
    return [(frame.truth, frame.image) for frame in map(_WORKER_PIPELINE.render, indices)]


def video_metadata(scene: Scene, n_frames: int, video: VideoSettings) -> dict[str, str]:
    """The container tags of a rendered video: the scene, seed and camera settings
    (as :func:`frame_text` gives them a PNG), the frame count and the encoding."""
    text = frame_text(scene, {"frame": 0, "start_s": 0.0})
    del text["frame"], text["start_s"], text["Software"]
    return {**text, "frames": str(n_frames), "frame_rate_hz": repr(scene.camera.frame_rate_hz),
            "encoding": video.describe(scene.camera.frame_rate_hz),
            "comment": f"rendered by rollsim {__version__}"}


def check_video_scene(scene: Scene, video: VideoSettings) -> None:
    """Refuse, before any frame, a scene whose frames the video cannot hold or this machine cannot encode."""
    from rollsim.errors import RollsimError
    from rollsim.video.settings import check_frames

    cam = scene.camera
    if cam.output not in ("gray8", "rgb8"):
        raise RollsimError(f"--container {video.container}: camera.output {cam.output}; a video holds 8-bit frames "
                           "(gray8 or rgb8)")
    check_frames(video, cam.width_px, cam.height_px, cam.output == "rgb8")


def _write_video(scene: Scene, n_frames: int, workers: int, directory: Path, truth_file,
                 video: VideoSettings, progress: Optional[Callable[[int], None]]) -> None:
    from rollsim.video.write import VideoWriter, video_name

    cam = scene.camera
    chunks = chunked(range(n_frames), chunk_frames(scene))
    with VideoWriter(directory / video_name(video), video, cam.width_px, cam.height_px, cam.frame_rate_hz,
                     cam.output == "rgb8", video_metadata(scene, n_frames, video)) as writer:
        for written, (truth, image) in enumerate(
                ordered_chunk_map(_render_images, chunks, workers, initializer=_init_worker, initargs=(scene,)),
                start=1):
            writer.write(image)
            truth_file.write(json.dumps(truth, separators=(",", ":")) + "\n")
            if progress is not None:
                progress(written)


def _written_frames(scene: Scene, n_frames: int, workers: int, frames_dir: Path,
                    decode: Optional[Callable] = None) -> Iterator[tuple]:
    """Render and write every frame; yield ``(truth record, what decode returned or None)`` in frame order."""
    chunks = chunked(range(n_frames), chunk_frames(scene))
    yield from ordered_chunk_map(_render_chunk, chunks, workers, frames_dir, decode, initializer=_init_worker,
                                 initargs=(scene,))


def render_to_dir(
    scene: Scene,
    out_dir: Path,
    n_frames: int,
    force: bool = False,
    workers: Optional[int] = None,
    progress: Optional[Callable[[int], None]] = None,
    inputs: Iterable = (),
    video: Optional[VideoSettings] = None,
) -> RenderSummary:
    """Render ``n_frames`` frames of ``scene`` into ``out_dir``.

    Writes ``frames/frame_000000.png`` …, ``truth.jsonl`` (one line per frame)
    and ``scene.resolved.yaml`` (every value after presets and overrides).
    The directory appears only when complete (see :mod:`rollsim.plumbing.outputs`).

    Parameters
    ----------
    scene : Scene
    out_dir : Path
    n_frames : int
    force : bool
        Replace a previous rollsim result in ``out_dir``.
    workers : int, optional
        Processes; default :func:`default_workers`.
    progress : callable, optional
        Called with the number of frames written after each frame.
    inputs : iterable of path, optional
        The command's input files, which ``out_dir`` must not hold.
    video : VideoSettings, optional
        Write the frames as one video, ``frames.mp4`` (or ``.mkv``), instead of PNGs.

    Raises
    ------
    RollsimError
        An unusable ``out_dir``, a frame too large for the memory budget,
        frames too many for the disk budget (:func:`check_render_disk`), or
        (exit code 1) an OS failure while writing: ``out_dir`` is then as it
        was.
    """
    if n_frames < 1:
        raise ValueError(f"n_frames must be >= 1, got {n_frames}")
    workers = default_workers() if workers is None else max(1, int(workers))
    if video is not None:
        check_video_scene(scene, video)
    check_render_memory(scene, workers)
    check_render_disk(scene, n_frames, Path(out_dir), video=video)
    _init_worker(scene)  # fails on an impossible scene before touching disk; kept for the render
    with staged_directory(Path(out_dir), force, inputs) as staging:
        render_into(scene, staging, n_frames, workers, progress, video=video)
    return RenderSummary(Path(out_dir), n_frames, workers)


# Below this many pixels a render runs the numpy twins of the compiled
# kernels: importing numba and loading its cache costs about a second per
# process, the numpy twins about 0.3 s per 1080p frame (the same frames).
SHORT_RENDER_PIXELS = 3 * 1920 * 1080


def is_short_render(scene: Scene, n_frames: int) -> bool:
    """Whether ``n_frames`` of ``scene`` are too few to pay for compiling (see :data:`SHORT_RENDER_PIXELS`)."""
    return n_frames * scene.camera.width_px * scene.camera.height_px < SHORT_RENDER_PIXELS


def render_into(scene: Scene, directory: Path, n_frames: int, workers: int, progress: Optional[Callable[[int], None]] = None,
                decode: Optional[Callable] = None, on_decoded: Optional[Callable] = None,
                video: Optional[VideoSettings] = None) -> None:
    """Write the frames, truth and resolved scene into an existing, empty ``directory``.

    The building block of :func:`render_to_dir`, for callers (``rollsim
    run``) that own the staged output directory themselves. With ``decode``
    (picklable: ``decode(index, image, path) -> result``, run in the workers on
    each frame as it is rendered), ``on_decoded(result)`` is called in frame
    order in this process. With ``video`` the frames go into one video file
    (``decode`` is then not supported).
    """
    if video is not None and decode is not None:
        raise ValueError("render_into: decode is not supported with a video output")
    (Path(directory) / "scene.resolved.yaml").write_text(scene_to_yaml(scene), encoding="utf-8")
    with numpy_only(is_short_render(scene, n_frames)), \
            open(Path(directory) / "truth.jsonl", "w", encoding="utf-8") as truth_file:
        _init_worker(scene)
        assert _WORKER_PIPELINE is not None  # built just above
        warm_up_render(_WORKER_PIPELINE)  # workers fork with the pipeline built and its kernels loaded
        if video is not None:
            _write_video(scene, n_frames, workers, Path(directory), truth_file, video, progress)
            return
        frames_dir = Path(directory) / "frames"
        frames_dir.mkdir()
        for written, (truth, decoded) in enumerate(_written_frames(scene, n_frames, workers, frames_dir, decode),
                                                   start=1):
            truth_file.write(json.dumps(truth, separators=(",", ":")) + "\n")
            if on_decoded is not None:
                on_decoded(decoded)
            if progress is not None:
                progress(written)
