"""Output directories written atomically.

A command that writes a directory of results renders into a fresh sibling
``DIR.partial-XXXX`` and renames it into place only when it is complete, so
an interrupted or failed run leaves ``DIR`` as it was. An existing non-empty
``DIR`` is never replaced unless the caller asks (``--force``).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from rollsim.errors import OutputError


def check_output_dir(out_dir: Path, force: bool) -> None:
    """Refuse a non-empty ``out_dir`` without ``force``, or an unusable one."""
    out_dir = Path(out_dir)
    if out_dir.exists():
        if not out_dir.is_dir():
            raise OutputError(f"{out_dir}: exists and is not a directory")
        if any(out_dir.iterdir()) and not force:
            raise OutputError(f"{out_dir}: directory is not empty; use --force to replace it")
    parent = out_dir.resolve().parent
    if not parent.is_dir():
        raise OutputError(f"{out_dir}: parent directory {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{out_dir}: cannot write in {parent} (permission denied)")


@contextlib.contextmanager
def atomic_output_dir(out_dir: Path, force: bool = False):
    """Yield a temporary directory that replaces ``out_dir`` on success.

    On an exception the temporary directory is removed and ``out_dir`` is
    untouched.
    """
    out_dir = Path(out_dir)
    check_output_dir(out_dir, force)
    try:
        partial = Path(tempfile.mkdtemp(prefix=f"{out_dir.name}.partial-", dir=out_dir.resolve().parent))
    except OSError as exc:
        raise OutputError(f"{out_dir}: cannot create a directory next to it ({exc.strerror})") from None
    try:
        yield partial
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise
    old = None
    if out_dir.exists():
        old = out_dir.resolve().parent / f"{partial.name}.old"
        os.rename(out_dir, old)
    os.rename(partial, out_dir)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)



def write_text_atomic(path: Path, text: str, force: bool = True) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file and a rename.

    Raises
    ------
    OutputError
        If ``path`` exists and ``force`` is false, or cannot be written.
    """
    write_bytes_atomic(path, text.encode("utf-8"), force)


def write_bytes_atomic(path: Path, data: bytes, force: bool = True) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename.

    Raises
    ------
    OutputError
        If ``path`` exists and ``force`` is false, or cannot be written.
    """
    with atomic_file(path, "wb", force) as handle:
        handle.write(data)


def refuse_existing(paths, force: bool) -> None:
    """One error naming every path of ``paths`` that exists, unless ``force``.

    Called before any work, so that a refused run costs nothing.
    """
    present = [str(p) for p in paths if Path(p).exists()]
    if present and not force:
        raise OutputError(f"{', '.join(present)}: exists; use --force to replace it")


@contextlib.contextmanager
def atomic_file(path: Path, mode: str = "w", force: bool = True):
    """Yield an open temporary file that replaces ``path`` when the block ends.

    On an exception the temporary file is removed and ``path`` is untouched.

    Raises
    ------
    OutputError
        If ``path`` exists and ``force`` is false, or cannot be written.
    """
    path = Path(path)
    refuse_existing([path], force)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with open(tmp, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as handle:
            yield handle
        os.replace(tmp, path)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({exc.strerror or exc})") from None
    finally:
        tmp.unlink(missing_ok=True)
