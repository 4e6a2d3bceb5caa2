"""One owner for outputs: how every directory and file rollsim writes is
staged, committed and replaced.

Every command goes through this module. The rules:

Directories (``render --out``, ``run --out``)
    The result is built in a staging area next to the target
    (``.NAME.rollsim-….staging``) and moved into place by one rename at the
    end. At that moment the target is checked again: if anything appeared in
    it meanwhile (another run, a file of the user's), nothing is replaced,
    the result is kept under a visible name given in the error, and the
    command fails with exit code 1.
Files (``--json``, ``--plot``, ``--markdown``, ``decoded.jsonl``, …)
    Written to a temporary file in the same directory, fsynced, and put in
    place by a hard link (which refuses to replace a file that appeared
    meanwhile) or, with ``--force``, a rename. Several files of one command
    are committed together: all of them or none.
Parent folders
    Missing folders above an output are made when it is written (as
    ``mkdir -p`` does), and removed again, if still empty, when the command
    fails.
Replacing
    Without ``--force`` nothing is replaced. ``--force`` replaces a file, and
    a directory only if it holds nothing but a previous rollsim result: every
    committed directory carries a manifest (:data:`MANIFEST_NAME`) of what
    rollsim wrote into it, with sizes and, for small files, SHA-256 digests,
    and a directory holding anything else is refused. Nothing the user wrote
    is ever deleted.
Dying
    A run that dies (SIGINT, SIGTERM, SIGKILL, full disk, read-only target)
    leaves the target as it was. Staging names carry the host, process id and
    process start time of their owner; the next run into the same place
    removes those of dead processes, and says so.
Modes
    New directories and files take the mode the umask gives (0755 and 0644
    under umask 022).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fnmatch
import hashlib
import json
import os
import re
import secrets
import shutil
import socket
import stat
import sys
from pathlib import Path
from typing import Callable, Iterable, Optional, Union

from rollsim.plumbing import signals
from rollsim.errors import CommitError, OutputError, SystemFailure

MANIFEST_NAME = ".rollsim-output.json"
# Files up to this size get a digest in the manifest (text a user might
# edit); larger ones (frames) are recognised by name and size.
_DIGEST_MAX_BYTES = 1 << 20
_KINDS = ("staging", "old", "tmp")
_SIBLING = re.compile(
    r"^\.(?P<target>.+)\.rollsim-(?P<host>[0-9a-f]{8})-(?P<pid>[0-9]+)-(?P<start>[0-9]+)-[0-9a-f]{8}"
    r"\.(?P<kind>staging|old|tmp)$"
)
_LEGACY = re.compile(r"^(?P<target>.+)\.partial-[^/]+$")

PathLike = Union[str, os.PathLike]


def notice(text: str) -> None:
    """Tell the user something that is not an error (stale staging removed)."""
    print(f"rollsim: {text}", file=sys.stderr)


# ------------------------------------------------------- who owns a sibling


def _host_tag() -> str:
    return hashlib.sha1(socket.gethostname().encode("utf-8", "replace")).hexdigest()[:8]


def _process_start(pid: int) -> Optional[int]:
    """Start time of process ``pid`` in clock ticks since boot (Linux), else None."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # The command name (field 2) may hold spaces and parentheses: split after it.
    fields = text[text.rfind(")") + 2 :].split()
    try:
        return int(fields[19])
    except (IndexError, ValueError):
        return None


def _owner_tag() -> str:
    pid = os.getpid()
    return f"{_host_tag()}-{pid}-{_process_start(pid) or 0}"


def _sibling(path: Path, kind: str) -> Path:
    """A fresh hidden name next to ``path`` that names this process as its owner."""
    return path.with_name(f".{path.name}.rollsim-{_owner_tag()}-{secrets.token_hex(4)}.{kind}")


def _process_alive(pid: int, start: int) -> bool:
    if pid == os.getpid():
        return True
    now = _process_start(pid)
    if now is not None:
        return start == 0 or now == start
    if Path("/proc/self/stat").exists():
        return False  # /proc works and has no such process
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clear_stale(path: PathLike) -> list[str]:
    """Remove the staging areas and temporary files of dead runs next to ``path``.

    A leftover of a forced replacement (``.old``) whose target is missing is
    put back instead. Leftovers of live processes, and of other hosts (on a
    shared file system), are left alone.

    Returns
    -------
    list of str
        One notice per leftover handled, already shown to the user.
    """
    path = Path(path)
    parent = path.parent
    try:
        entries = list(os.scandir(parent))
    except OSError:
        return []
    notices = []
    host = _host_tag()
    for entry in entries:
        match = _SIBLING.match(entry.name)
        if match is None:
            legacy = _LEGACY.match(entry.name)
            if legacy and legacy.group("target") == path.name and entry.is_dir(follow_symlinks=False):
                notices.append(f"note: {entry.path} looks like the staging area of an older rollsim; "
                               "remove it if no run is writing there")
            continue
        if match.group("target") != path.name or match.group("host") != host:
            continue
        pid, start = int(match.group("pid")), int(match.group("start"))
        if _process_alive(pid, start):
            continue
        leftover = Path(entry.path)
        if match.group("kind") == "old" and not os.path.lexists(path):
            os.rename(leftover, path)
            notices.append(f"restored {path} from {leftover}, left by a run (process {pid}) that died while replacing it")
        else:
            _remove(leftover)
            what = "staging area" if match.group("kind") == "staging" else "temporary file"
            notices.append(f"removed stale {what} {leftover} of a run (process {pid}) that is no longer running")
    for text in notices:
        notice(text)
    return notices


def is_staging(path: PathLike) -> bool:
    """Whether ``path`` is the staging area of a run (finished or not)."""
    match = _SIBLING.match(Path(path).resolve().name)
    return match is not None and match.group("kind") == "staging"


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


# --------------------------------------------------------------- manifests


def _file_record(path: Path) -> dict:
    size = path.stat().st_size
    record: dict = {"size": size}
    if size <= _DIGEST_MAX_BYTES:
        record["sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    return record


def _tree(directory: Path) -> tuple[list[str], list[str], list[str]]:
    """Relative POSIX paths of the directories, files and other entries under ``directory``."""
    dirs, files, other = [], [], []
    for root, subdirs, names in os.walk(directory):
        base = Path(root)
        for name in subdirs + names:
            full = base / name
            rel = full.relative_to(directory).as_posix()
            mode = full.lstat().st_mode
            if stat.S_ISDIR(mode):
                dirs.append(rel)
            elif stat.S_ISREG(mode):
                files.append(rel)
            else:
                other.append(rel)  # symlinks, sockets: rollsim writes none
    return sorted(dirs), sorted(files), sorted(other)


def write_manifest(directory: PathLike, patterns: Iterable[str] = ()) -> None:
    """Record everything under ``directory`` as rollsim's (a result at its commit).

    Parameters
    ----------
    directory : path
    patterns : iterable of str, optional
        :mod:`fnmatch` patterns of relative paths that rollsim owns whatever
        their content, for a directory that grows as a run goes (a sweep's
        journal of cells).
    """
    directory = Path(directory)
    dirs, files, _ = _tree(directory)
    data = {"rollsim_output": 1, "dirs": dirs, "patterns": sorted(patterns),
            "files": {rel: _file_record(directory / rel) for rel in files if rel != MANIFEST_NAME}}
    _save_manifest(directory, data)


def _save_manifest(directory: Path, data: dict) -> None:
    text = json.dumps(data, indent=1, sort_keys=True) + "\n"
    _write_and_replace(directory / MANIFEST_NAME, text.encode("utf-8"))


def _manifest_root(path: Path, levels: int = 3) -> Optional[Path]:
    """The nearest directory above ``path`` (at most ``levels`` up) that holds a manifest."""
    for parent in list(path.parents)[:levels]:
        if (parent / MANIFEST_NAME).is_file():
            return parent
    return None


def record_files(paths: Iterable[Path]) -> None:
    """Add files just committed into a rollsim output to its manifest (if they are in one)."""
    roots: dict[Path, list[Path]] = {}
    for path in paths:
        root = _manifest_root(path)
        if root is not None:
            roots.setdefault(root, []).append(path)
    for root, members in roots.items():
        data = read_manifest(root)
        if data is None:
            continue
        for path in members:
            rel = path.relative_to(root).as_posix()
            if not _owned_by_pattern(rel, data):  # a journal's files are owned already
                data["files"][rel] = _file_record(path)
                parts = rel.split("/")[:-1]
                data["dirs"] = sorted(set(data["dirs"]) | {"/".join(parts[: k + 1]) for k in range(len(parts))})
        _save_manifest(root, data)


def _owned_by_pattern(rel: str, data: dict) -> bool:
    return any(fnmatch.fnmatchcase(rel, pattern) for pattern in data.get("patterns", ()))


def read_manifest(directory: PathLike) -> Optional[dict]:
    """The manifest of a rollsim output directory, or None."""
    try:
        data = json.loads((Path(directory) / MANIFEST_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not (isinstance(data, dict) and isinstance(data.get("files"), dict) and isinstance(data.get("dirs"), list)):
        return None
    return data


def foreign_entries(directory: PathLike) -> list[str]:
    """Entries of ``directory`` that rollsim did not write (or that changed since).

    Everything is foreign in a directory without a manifest.
    """
    directory = Path(directory)
    data = read_manifest(directory)
    dirs, files, other = _tree(directory)
    if data is None:
        return dirs + files + other
    known_dirs = set(data["dirs"])
    foreign = [d for d in dirs if d not in known_dirs and not _owned_by_pattern(d, data)] + other
    for rel in files:
        if rel == MANIFEST_NAME or _owned_by_pattern(rel, data):
            continue
        record = data["files"].get(rel)
        if not isinstance(record, dict) or (directory / rel).stat().st_size != record.get("size"):
            foreign.append(rel)
        elif "sha256" in record and _file_record(directory / rel).get("sha256") != record["sha256"]:
            foreign.append(rel)
    return sorted(foreign)


def _list_some(names: list[str], limit: int = 3) -> str:
    shown = ", ".join(names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


# ---------------------------------------------------------- checks up front


def _is_within(path: Path, root: Path) -> bool:
    return path == root or root in path.parents


def _missing_folders(path: Path) -> list[Path]:
    """The folders above ``path`` that do not exist, outermost first."""
    missing: list[Path] = []
    folder = Path(os.path.abspath(path)).parent
    while not os.path.lexists(folder) and folder.parent != folder:
        missing.insert(0, folder)
        folder = folder.parent
    return missing


def _check_parent(path: Path, shown: Path) -> None:
    """Refuse ``path`` (named ``shown``) where its folder cannot be made or written in.

    The nearest folder above it that exists must be a directory rollsim may
    write in; the missing ones below it are made when the output is written
    (:func:`parent_folders`).
    """
    missing = _missing_folders(path)
    existing = (missing[0] if missing else Path(os.path.abspath(path))).parent
    if not existing.is_dir():
        # Named as the user wrote it: afile/out: afile is not a directory.
        named = next((p for p in Path(shown).parents if os.path.lexists(p)), existing)
        raise OutputError(f"{shown}: {named} is not a directory")
    _check_writable_dir(existing, shown)


def _check_writable_dir(directory: Path, what: Path) -> None:
    """The OS's refusal to write in ``directory``, as a one-line failure."""
    try:
        read_only = bool(os.statvfs(directory).f_flag & os.ST_RDONLY)
    except OSError as exc:
        raise SystemFailure(f"{what}: cannot use {directory} ({exc.strerror})") from None
    if read_only:
        raise SystemFailure(f"{what}: {directory} is on a read-only file system")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise SystemFailure(f"{what}: cannot write in {directory} (permission denied)")


def _real_target(target: Path) -> Path:
    """The absolute target, through a symbolic link to it (the link itself stays)."""
    return Path(os.path.realpath(target))


def check_directory_target(target: PathLike, force: bool = False, inputs: Iterable[PathLike] = ()) -> Path:
    """Refuse an unusable output directory before any work.

    Refused: the working directory or a directory holding it, a directory
    holding (or equal to) an input, a non-directory, a parent that cannot be
    made (a file on the way), a non-empty directory without ``force``, and
    with ``force`` one that holds anything but a previous rollsim result.
    Missing parent folders are made when the output is written.

    Returns
    -------
    Path
        The target's real path.

    Raises
    ------
    OutputError
        A target the user must change (exit 2).
    SystemFailure
        A target the OS will not let rollsim write (exit 1).
    """
    target = Path(target)
    real = _real_target(target)
    if _is_within(Path.cwd().resolve(), real):
        raise OutputError(f"{target}: is the working directory or holds it; give a new directory for the output")
    for item in inputs:
        if item is not None and _is_within(_real_target(Path(item)), real):
            raise OutputError(f"{target}: holds the input {item}; give a directory apart from the inputs")
    _check_parent(real, target)
    if os.path.lexists(real):
        if not real.is_dir():
            raise OutputError(f"{target}: exists and is not a directory")
        if any(real.iterdir()):
            if not force:
                raise OutputError(f"{target}: directory is not empty; use --force to replace a previous rollsim output")
            _check_replaceable(target, real)
    return real


def _check_replaceable(target: Path, real: Path) -> None:
    foreign = foreign_entries(real)
    if read_manifest(real) is None:
        raise OutputError(f"{target}: not a rollsim output (no {MANIFEST_NAME}); --force replaces only rollsim's own "
                          "results: move it away or give another directory")
    if foreign:
        raise OutputError(f"{target}: holds files rollsim did not write (or that changed since): {_list_some(foreign)}; "
                          "--force replaces only rollsim's own results")
    for root, _, _ in os.walk(real):
        _check_writable_dir(Path(root), target)  # its entries must be deletable


def check_file_targets(paths: Iterable[Optional[PathLike]], force: bool = False) -> list[Path]:
    """Refuse unusable output files before any work (``--json``, ``--plot``, …).

    ``None`` entries (options not given) are skipped.

    Raises
    ------
    OutputError
        A directory, a parent that cannot be made (a file on the way), the
        same file twice, or an existing file without ``force`` (exit 2).
    SystemFailure
        A directory the OS will not let rollsim write in (exit 1).
    """
    checked: list[Path] = []
    for item in paths:
        if item is None:
            continue
        path = Path(item)
        real = _real_target(path)
        if real in [_real_target(p) for p in checked]:
            raise OutputError(f"{path}: given for two outputs")
        if real.is_dir():
            raise OutputError(f"{path}: is a directory; give a file name")
        if os.path.lexists(real) and not force:
            raise OutputError(f"{path}: exists; use --force to replace it")
        _check_parent(real, path)
        checked.append(path)
    return checked


# ------------------------------------------------------------- OS failures


@contextlib.contextmanager
def os_failures(staging: Optional[Path] = None, target: Optional[Path] = None):
    """Turn an OSError (full disk, read-only file system, …) into a one-line :class:`SystemFailure`.

    Paths inside ``staging`` are named as the user's ``target``.
    """
    try:
        yield
    except OSError as exc:
        raise SystemFailure(describe_os_error(exc, staging, target)) from None


def describe_os_error(exc: OSError, staging: Optional[Path] = None, target: Optional[Path] = None) -> str:
    """``PATH: strerror``, with a staging path named as its target."""
    name = exc.filename if exc.filename is not None else target
    reason = exc.strerror or str(exc) or type(exc).__name__
    tail = f"; {target} was left as it was" if target is not None else ""
    if name is None:
        return f"{reason}{tail}"
    text = str(name)
    if staging is not None and target is not None:
        text = text.replace(str(staging), str(target))
    return f"{text}: {reason}{tail}"


# ----------------------------------------------------- directory outputs


def _rename_exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2(RENAME_EXCHANGE)``); False where unsupported."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        function = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    if function(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _keep(result: Path, target: Path) -> Path:
    """Give an uncommitted result a visible name next to its target."""
    for n in range(1, 10_000):
        kept = target.with_name(f"{target.name}.rollsim-uncommitted-{os.getpid()}" + (f"-{n}" if n > 1 else ""))
        if not os.path.lexists(kept):
            os.rename(result, kept)
            return kept
    raise SystemFailure(f"{target}: cannot find a free name to keep {result}")  # pragma: no cover


def _changed(target: Path, result: Path, why: str, shown: Optional[Path] = None) -> CommitError:
    shown = shown or target
    kept = shown.with_name(_keep(result, target).name)
    return CommitError(f"{shown}: {why} while this run was working; nothing was replaced and this run's "
                       f"result is kept in {kept}")


def _commit_directory(staging: Path, target: Path, force: bool, shown: Path) -> None:
    """Rename ``staging`` to ``target`` (named ``shown`` to the user), checking the target again."""
    with signals.deferred():
        if os.path.lexists(target) and target.is_dir() and any(target.iterdir()):
            if not force:
                raise _changed(target, staging, "something was written into it", shown)
            _replace_directory(staging, target, shown)
            return
        try:
            os.rename(staging, target)  # atomic; refuses a target that is not an empty directory
        except OSError as exc:
            if exc.errno in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR, errno.EISDIR):
                raise _changed(target, staging, "something was written into it", shown) from None
            raise


def _replace_directory(staging: Path, target: Path, shown: Path) -> None:
    """Put ``staging`` in place of a previous rollsim result (``--force``)."""
    foreign = foreign_entries(target)
    if foreign:
        raise _changed(target, staging, f"files rollsim did not write appeared in it ({_list_some(foreign)})", shown)
    if _rename_exchange(staging, target):
        old = staging
    else:
        old = _sibling(target, "old")
        os.rename(target, old)
        try:
            os.rename(staging, target)
        except BaseException:
            os.rename(old, target)
            raise
    # A file written into the old result between the check and the swap is
    # the user's: swap back rather than delete it.
    foreign = foreign_entries(old)
    if foreign:
        if _rename_exchange(old, target):
            raise _changed(target, old, f"files rollsim did not write appeared in it ({_list_some(foreign)})", shown)
        raise CommitError(f"{shown}: files rollsim did not write appeared in the previous result while it was "
                          f"being replaced ({_list_some(foreign)}); that result is kept in {_keep(old, target)}")
    shutil.rmtree(old)


@contextlib.contextmanager
def parent_folders(paths: Iterable[Optional[PathLike]]):
    """Make the missing folders above each of ``paths`` (as ``mkdir -p`` does) for the block.

    When the block fails, the folders made here are removed again if they
    are still empty: a command refused or failed on the way leaves no empty
    folder behind, and nothing of anyone's is removed. ``None`` entries are
    skipped.
    """
    made: list[Path] = []
    try:
        for path in paths:
            if path is None:
                continue
            for folder in _missing_folders(Path(path)):
                try:
                    os.mkdir(folder)  # mode 0777 less the umask
                except FileExistsError:
                    continue  # made meanwhile by another run: not ours to remove
                except OSError as exc:
                    raise SystemFailure(describe_os_error(exc, target=Path(path))) from None
                made.append(folder)
        yield
    except BaseException:
        with signals.deferred():
            for folder in reversed(made):
                with contextlib.suppress(OSError):
                    folder.rmdir()  # only if still empty
        raise


def create_directory(target: PathLike, force: bool = False, inputs: Iterable[PathLike] = (),
                     patterns: Iterable[str] = ()) -> Path:
    """Create an output directory that fills up as the work goes (a sweep's journal).

    Unlike :func:`staged_directory`, the directory is the target from the
    start, so that an interrupted run keeps what it committed; every file
    goes into it through :func:`staged_files`. Its manifest owns the
    ``patterns`` (what the run appends) and the files committed later.

    Returns
    -------
    Path
        The directory's real path.

    Raises
    ------
    OutputError, SystemFailure
        As :func:`check_directory_target`.
    """
    target = Path(target)
    real = check_directory_target(target, force, inputs)
    clear_stale(real)
    with parent_folders([real]), os_failures(target=target), signals.deferred():
        if os.path.lexists(real) and any(real.iterdir()):
            old = _sibling(real, "old")
            os.rename(real, old)  # a previous rollsim result (checked): set aside, then removed
            os.mkdir(real)
            shutil.rmtree(old)
        elif not os.path.lexists(real):
            os.mkdir(real)
        write_manifest(real, patterns)
    return real


def _make_staging(real: Path) -> Path:
    staging = _sibling(real, "staging")
    os.mkdir(staging)  # mode 0777 less the umask, unlike mkdtemp's 0700
    return staging


@contextlib.contextmanager
def staged_directory(target: PathLike, force: bool = False, inputs: Iterable[PathLike] = ()):
    """Yield a staging directory that becomes ``target`` when the block ends.

    Parameters
    ----------
    target : path
        The output directory.
    force : bool
        Replace a previous rollsim result there.
    inputs : iterable of path
        The command's inputs, which the target must not hold.

    Yields
    ------
    Path
        An empty directory to write the result into.

    Raises
    ------
    OutputError, SystemFailure, CommitError
        See :func:`check_directory_target`; an OS failure during the work
        (the target is left as it was); a target that changed meanwhile
        (the result is kept, named in the message).
    """
    target = Path(target)
    real = check_directory_target(target, force, inputs)
    clear_stale(real)
    staging: Optional[Path] = None
    with parent_folders([real]):
        try:
            with os_failures(staging, target):
                staging = _make_staging(real)
            with os_failures(staging, target):
                yield staging
                write_manifest(staging)
                _commit_directory(staging, real, force, target)
        except BaseException:
            if staging is not None and os.path.lexists(staging):
                with signals.deferred():
                    shutil.rmtree(staging, ignore_errors=True)
            raise


# --------------------------------------------------------------- files


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass  # some file systems cannot sync a directory; the rename is done
    finally:
        os.close(fd)


def _open_new(path: Path, binary: bool):
    """Create ``path`` exclusively, mode 0666 less the umask."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o666)
    return os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline="")


def _write_and_replace(path: Path, data: bytes) -> None:
    tmp = _sibling(path, "tmp")
    try:
        with _open_new(tmp, True) as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.lexists(tmp):
            tmp.unlink()


class _Appeared(Exception):
    """A target file appeared during the commit (handled by :func:`staged_files`)."""


class StagedFiles:
    """Files written to temporaries, then committed together: all or none.

    Use it through :func:`staged_files`.
    """

    def __init__(self, force: bool):
        self.force = force
        self._staged: dict[Path, Path] = {}  # target -> temporary

    def open(self, target: PathLike, mode: str = "w"):
        """A new temporary file for ``target``; ``mode`` is ``"w"`` or ``"wb"``."""
        target = _real_target(Path(target))
        if target in self._staged:
            raise ValueError(f"{target}: staged twice")
        clear_stale(target)
        tmp = _sibling(target, "tmp")
        handle = _open_new(tmp, "b" in mode)
        self._staged[target] = tmp
        return handle

    def write(self, target: PathLike, data: Union[str, bytes]) -> None:
        """Stage ``data`` (text is written as UTF-8) for ``target``."""
        with self.open(target, "wb") as handle:
            handle.write(data.encode("utf-8") if isinstance(data, str) else data)

    def _sync_all(self) -> None:
        for tmp in self._staged.values():
            with open(tmp, "rb+") as handle:
                os.fsync(handle.fileno())

    def commit(self) -> None:
        """Put every staged file in place, or none of them."""
        self._sync_all()
        with signals.deferred():
            present = [t for t in self._staged if os.path.lexists(t)]
            if present and not self.force:
                raise self._keep_all(f"{_list_some([str(p) for p in present])}: appeared while this run was working "
                                     "(and --force was not given)")
            backups: dict[Path, Path] = {}
            placed: list[Path] = []
            try:
                for target in present:
                    backups[target] = _sibling(target, "old")
                    os.rename(target, backups[target])
                for target, tmp in self._staged.items():
                    self._place(tmp, target)
                    placed.append(target)
            except BaseException:
                for target in placed:
                    tmp = self._staged[target]
                    if os.path.lexists(tmp):
                        target.unlink(missing_ok=True)
                    else:  # placed by a rename: move it back to be kept
                        os.rename(target, tmp)
                for target, backup in backups.items():
                    if os.path.lexists(backup) and not os.path.lexists(target):
                        os.rename(backup, target)
                raise
            # Temporaries go only now: until every file is placed, each new
            # file can still be withdrawn and kept.
            for tmp in self._staged.values():
                tmp.unlink(missing_ok=True)
            for backup in backups.values():
                backup.unlink(missing_ok=True)
            for directory in {t.parent for t in self._staged}:
                _fsync_dir(directory)
            record_files(self._staged)
            self._staged.clear()

    def _place(self, tmp: Path, target: Path) -> None:
        try:
            os.link(tmp, target)  # fails if the target appeared meanwhile
        except FileExistsError:
            raise self._appeared(target) from None
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.EXDEV, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EMLINK):
                raise
            if os.path.lexists(target):  # no hard links here: check, then rename
                raise self._appeared(target) from None
            os.rename(tmp, target)

    def _appeared(self, target: Path) -> "_Appeared":
        return _Appeared(f"{target}: appeared while this run was working")

    def _keep_all(self, why: str) -> CommitError:
        kept = [str(_keep(tmp, target)) for target, tmp in self._staged.items() if os.path.lexists(tmp)]
        self._staged.clear()
        return CommitError(f"{why}; nothing was replaced and this run's result is kept in {', '.join(kept)}")

    def describe(self) -> str:
        """The staged targets, for an error line."""
        return _list_some([str(t) for t in self._staged]) or "output"

    def discard(self) -> None:
        """Remove every staged temporary (the command failed)."""
        for tmp in self._staged.values():
            tmp.unlink(missing_ok=True)
        self._staged.clear()


@contextlib.contextmanager
def staged_files(targets: Iterable[Optional[PathLike]] = (), force: bool = False):
    """Yield a :class:`StagedFiles`; commit its files when the block ends.

    Parameters
    ----------
    targets : iterable of path
        Checked up front with :func:`check_file_targets` (``None`` skipped);
        their missing folders are made (:func:`parent_folders`).
    force : bool
        Replace existing files.
    """
    targets = list(targets)
    check_file_targets(targets, force)
    files = StagedFiles(force)
    with parent_folders(targets):
        try:
            try:
                yield files
                files.commit()
            except _Appeared as exc:
                raise files._keep_all(str(exc)) from None
            except OSError as exc:
                raise SystemFailure(f"{files.describe()}: {exc.strerror or exc}; nothing was written") from None
        except BaseException:
            with signals.deferred():
                files.discard()
            raise


def write_file(path: PathLike, data: Union[str, bytes], force: bool = False) -> None:
    """Write one file atomically under the rules above (text as UTF-8)."""
    with staged_files([path], force) as files:
        files.write(path, data)


def write_files(contents: dict, force: bool = False) -> None:
    """Write several files (``{path: str or bytes}``) together: all or none."""
    with staged_files(list(contents), force) as files:
        for path, data in contents.items():
            files.write(path, data)


def check_directory_files(directory: PathLike, names: Iterable[str], force: bool = False) -> list[Path]:
    """Check, before any work, the files a command will write into ``directory``, which may not exist yet.

    A missing ``directory`` (and its missing parents) is made only when the
    files are written (:func:`write_files`), so a command refused or failed
    on the way leaves no empty folder behind.

    Raises
    ------
    OutputError, SystemFailure
        As :func:`check_file_targets`; ``directory`` a file.
    """
    directory = Path(directory)
    if os.path.lexists(directory) and not directory.is_dir():
        raise OutputError(f"{directory}: exists and is not a directory")
    return check_file_targets([directory / name for name in names], force)


def figure_png(draw: Callable[[object], None]) -> bytes:
    """PNG bytes of a plot that ``draw(file)`` saves to a file object."""
    import io

    buffer = io.BytesIO()
    draw(buffer)
    return buffer.getvalue()
