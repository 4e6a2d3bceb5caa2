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
    path = Path(path)
    if path.exists() and not force:
        raise OutputError(f"{path}: exists; use --force to replace it")
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(f"{path}: cannot write ({exc.strerror})") from None
