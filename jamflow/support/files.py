"""Files written atomically, output directories that leave no debris, and paths refused before work (stdlib only)."""

from __future__ import annotations

import contextlib
import contextvars
import csv
import errno
import fcntl
import glob
import json
import os
import re
import socket
import stat
import tempfile
from pathlib import Path

_REPLACEABLE: contextvars.ContextVar[frozenset] = contextvars.ContextVar("jamflow_replaceable", default=frozenset())


@contextlib.contextmanager
def replacing(paths):
    """Within the block, writes may replace these paths even if they are symlinks, device
    nodes, FIFOs or read-only files (the commands' ``--force``)."""
    token = _REPLACEABLE.set(_REPLACEABLE.get() | {os.path.abspath(p) for p in paths})
    try:
        yield
    finally:
        _REPLACEABLE.reset(token)


@contextlib.contextmanager
def atomic_path(path, force: bool = False):
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success.

    An existing regular file keeps its permission bits. ``force`` (or ``replacing``):
    replace a symlink, device node, FIFO or read-only file (refused otherwise)."""
    path = Path(path)
    check_writable(path, force)
    keep = path.is_file() and not path.is_symlink()
    mode = path.stat().st_mode & 0o7777 if keep else 0o666 & ~_umask()
    remove_stale_temporaries(path)
    fd, tmp = tempfile.mkstemp(prefix=_temporary_prefix(path, os.getpid()), suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        os.chmod(tmp, mode | 0o200)  # mkstemp makes 0600; the owner writes it, then it gets the final mode
        yield Path(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        if keep:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    except Exception as err:
        if out_of_space(err):  # h5py, matplotlib, numpy: each words it its own way
            raise DiskFull(path) from None
        raise
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_csv(path, rows, fieldnames=None) -> Path:
    """Write dict ``rows`` as CSV atomically, columns ``fieldnames`` (default: the first row's keys)."""
    rows = list(rows)
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        if rows or fieldnames:
            writer = csv.DictWriter(fh, fieldnames=list(fieldnames or rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    return Path(path)


_NO_SPACE = (errno.ENOSPC, errno.EDQUOT)


def out_of_space(err: BaseException) -> bool:
    """Whether ``err`` reports a full disk or quota: an OSError with errno ENOSPC or EDQUOT, or
    an error whose text carries it (h5py raises RuntimeError "... errno = 28 ..." from a failed
    flush and OSError "[Errno 28] ..." from a failed write)."""
    if isinstance(err, OSError) and err.errno in _NO_SPACE:
        return True
    text = str(err)
    return any(f"errno = {code}," in text or os.strerror(code) in text for code in _NO_SPACE)


class DiskFull(OSError):
    """A write ran out of space: what, where, and what to do, in one line (errno ENOSPC)."""

    def __init__(self, path):
        path = Path(path)
        super().__init__(errno.ENOSPC, f"cannot write {path}: no space left on the device holding "
                                       f"{path.parent if str(path.parent) else Path('.')} (disk or quota full); "
                                       "nothing was written there (earlier files are untouched); free space and rerun",
                         str(path))

    def __str__(self) -> str:
        return self.strerror


def _temporary_prefix(path: Path, pid: int) -> str:
    """``.NAME.HOST.PID.`` : atomic_path's temporary files name the output, the host and the
    process writing them (mkstemp adds 8 random characters and ``.tmp``)."""
    return f".{path.name}.{_HOST}.{pid}."


_HOST = re.sub(r"[^A-Za-z0-9_-]", "-", socket.gethostname()) or "host"


_RANDOM = r"[a-z0-9_]{8}"  # tempfile's random part


def remove_stale_temporaries(path) -> list[Path]:
    """Remove the temporary files that atomic_path left beside ``path`` in processes that are
    gone (a SIGKILL, a power cut): only names of atomic_path's pattern for this output, written
    on this host by a process id that no longer exists (a live writer's file is kept, also
    another user's). Returns the files removed."""
    path = Path(path)
    mine = re.compile(re.escape(f".{path.name}.{_HOST}.") + r"(\d+)\." + _RANDOM + r"\.tmp")
    removed = []
    for tmp in path.parent.glob(f".{glob.escape(path.name)}.*.tmp"):
        match = mine.fullmatch(tmp.name)
        if match and not _alive(int(match.group(1))) and tmp.is_file() and not tmp.is_symlink():
            tmp.unlink(missing_ok=True)
            removed.append(tmp)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's process
    return True


@contextlib.contextmanager
def output_directory(path, option: str | None = None):
    """Create the output directory ``path`` (its parent must exist) for the block; if the block
    fails or is interrupted and the directory was made here and is still empty, remove it. A
    directory that cannot be made is a one-line ValueError naming ``option`` (``--out``)."""
    path = Path(path)
    made = not path.exists()
    try:
        path.mkdir(exist_ok=True)
    except OSError as err:
        advice = f"; choose another {option}" if option else ""
        raise ValueError(f"cannot create the output directory {path}: {_reason(err)}{advice}") from None
    try:
        yield path
    except BaseException:
        if made and path.is_dir() and all(p.name == LOCK for p in path.iterdir()):
            (path / LOCK).unlink(missing_ok=True)  # only a lock taken inside the block: empty
            path.rmdir()
        raise


LOCK = ".lock"


class DirectoryLocked(ValueError):
    """Another process holds the directory's lock."""


def lock_directory(directory, busy: str):
    """Take the exclusive lock of ``directory`` (``flock`` on DIR/.lock, without waiting) and
    return the open lock file (closing it releases the lock; so does the process ending, also
    by SIGKILL). Raise DirectoryLocked(``busy``) if another process holds it."""
    fh = open(Path(directory) / LOCK, "a")
    try:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.close()
        raise DirectoryLocked(busy) from None
    return fh


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_KINDS = ((stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"), (stat.S_ISFIFO, "FIFO (named pipe)"),
          (stat.S_ISSOCK, "socket"))


def check_writable(path, force: bool = False, option: str | None = None) -> None:
    """Raise a clear ValueError before any work starts if ``path`` cannot or should not be
    written: missing or read-only directory (read-only file system, permission denied, no
    space: found by creating and removing a probe file there, which also holds for root), a
    directory, and -- unless ``force`` -- a symlink, a device node, FIFO or socket, or a
    read-only file (writing replaces the path itself with a new regular file). ``option``:
    the command's option that chooses ``path`` (such as ``--out``), named in the advice;
    None for a path that the command derives from its inputs."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    advice = f"choose another {option}" if option else "write beside a copy of the input in a writable directory"
    if not parent.is_dir():
        raise ValueError(f"cannot write {path}: directory {parent} does not exist; create it first")
    problem = _unwritable(parent)
    if problem:
        raise ValueError(f"cannot write {path}: directory {parent} is not writable ({problem}); {advice}")
    if path.is_dir():
        raise ValueError(f"cannot write {path}: it is a directory; give a file name such as packing.h5")
    if force or os.path.abspath(path) in _REPLACEABLE.get() or not os.path.lexists(path):
        return
    if path.is_symlink():
        raise ValueError(f"refusing to write {path}: it is a symbolic link (to {os.readlink(path)}) and writing "
                         "would replace the link; give the target's path, or --force to replace the link")
    mode = path.stat().st_mode
    for test, kind in _KINDS:
        if test(mode):
            raise ValueError(f"refusing to write {path}: it is a {kind}, not a regular file, and writing would "
                             "replace it; choose a file name, or --force to replace it")
    if not mode & 0o222 or not os.access(path, os.W_OK):
        raise ValueError(f"refusing to overwrite {path}: it is read-only; make it writable (chmod u+w), "
                         "choose another name, or --force to replace it")


def _reason(err: OSError) -> str:
    """An OSError's cause in words (``read-only file system``), without the traceback's path."""
    return (os.strerror(err.errno) if err.errno else str(err)).lower()


def _unwritable(directory) -> str | None:
    """Why no file can be created in ``directory`` (its errno in words), or None if one can.
    Creates and removes a probe file: ``os.access`` says yes to root on a read-only mount."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".jamflow-probe.", dir=directory)
    except OSError as err:
        return _reason(err)
    os.close(fd)
    os.unlink(probe)
    return None


FILE_SYSTEM_ERRNOS = (errno.EROFS, errno.EACCES, errno.EPERM, errno.ENOSPC, errno.EDQUOT)


def file_system_refusal(err: BaseException) -> str | None:
    """One line for an OSError the file system raised while writing (read-only file system,
    permission denied, no space): ``cannot write PATH: reason``; None for any other error."""
    if not isinstance(err, OSError) or err.errno not in FILE_SYSTEM_ERRNOS:
        return None
    where = f" {err.filename}" if err.filename else ""
    return f"cannot write{where}: {_reason(err)}; choose a writable location and rerun"


def check_not_input(path, inputs) -> None:
    """Raise a clear ValueError before any work starts if the output ``path`` is one of the input
    files (by path, symlink or hard link): writing it would replace the packing the run starts from."""
    for source in inputs:
        if os.path.exists(path) and os.path.exists(source) and os.path.samefile(path, source):
            raise ValueError(f"--out {path} is the input {source}: writing it would replace the packing this run "
                             "starts from; choose another name")


def read_json(path, what: str):
    """The JSON document in the file ``path`` (a ``what``); a one-line ValueError naming the file
    if it is not valid JSON (damaged, truncated), so that it reads as bad input, not a bug."""
    try:
        return json.loads(Path(path).read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"{path} is not a valid {what}: damaged JSON ({err}); remove it or rerun the command "
                         "that wrote it") from None


def check_distinct(files) -> list[str]:
    """``files`` if no two resolve to the same file (symlinks, ``./``, a store directory and one of
    its files); else a one-line ValueError: a file given twice would count as two packings in the
    averages (D(omega), g(r), ...)."""
    seen = {}
    for name in files:
        key = os.path.realpath(name)
        if key in seen:
            same = f"as {seen[key]} and {name}" if seen[key] != name else "twice"
            raise ValueError(f"{name} is given {same} (the same file {key}): it would count as two packings; "
                             "give each packing file once")
        seen[key] = name
    return list(files)
