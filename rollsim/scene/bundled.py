"""The scenes bundled with rollsim (the ``scenes/`` folder)."""

from __future__ import annotations

import difflib
from importlib import resources
from pathlib import Path
from typing import Optional, Union

from rollsim.errors import SceneError, clip
from rollsim.plumbing.validation import missing_path


class SceneNameError(SceneError):
    """A scene name no file can have (too long, a NUL character)."""


def bundled_scene_dir() -> Path:
    """Folder of the bundled scene files."""
    return Path(str(resources.files("rollsim.bundled_scenes")))


def bundled_scene_paths() -> list[Path]:
    """Bundled scene files, sorted by name."""
    return sorted(bundled_scene_dir().glob("*.yaml"))


def resolve_scene_path(path: Union[str, Path]) -> Path:
    """A scene file path, or the path of the bundled scene of that name.

    An existing file wins; otherwise ``NAME`` or ``NAME.yaml`` is looked up
    among the bundled scenes. A path that matches neither is returned as is,
    so that reading it reports it as not found.

    Raises
    ------
    SceneNameError
        A name no file can have (too long, a NUL character).
    """
    candidate = Path(path)
    try:
        if candidate.exists():
            return candidate
    except (OSError, ValueError) as exc:  # a name too long, a NUL character
        reason = getattr(exc, "strerror", None) or str(exc)
        raise SceneNameError(f"{clip(str(path), 120)}: not a usable scene file name ({reason})") from None
    name = candidate.name[:-5] if candidate.name.endswith(".yaml") else candidate.name
    if candidate.parent == Path("."):
        bundled = bundled_scene_dir() / f"{name}.yaml"
        if bundled.exists():
            return bundled
    return candidate


def missing_scene(scene: Union[str, Path]) -> Optional[str]:
    """The one-line refusal of a scene that is neither a file nor a bundled scene's name, or None.

    A bare name is looked up among the bundled scenes too, so the line says
    so, with the nearest bundled name: ``paper-defualt: does not exist, as
    a file or a bundled scene (did you mean paper-default? rollsim scenes
    lists them)``. A name no file can have is left to the loader (None).
    """
    try:
        path = resolve_scene_path(scene)
    except SceneNameError:
        return None
    problem = missing_path(path)
    if problem is None or path.parent != Path(".") or not problem.endswith(": does not exist"):
        return problem
    stem = path.name[:-5] if path.name.endswith(".yaml") else path.name
    close = difflib.get_close_matches(stem, [p.stem for p in bundled_scene_paths()], n=1)
    hint = f"did you mean {close[0]}? " if close else ""
    return f"{problem}, as a file or a bundled scene ({hint}rollsim scenes lists them)"
