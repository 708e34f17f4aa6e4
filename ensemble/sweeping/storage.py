"""Storage faults and the writer's lock: what a sweep does when the disk fills, the store turns read-only or
vanishes, or a second writer starts on the same store.

* :func:`storage_faults` turns an ``OSError`` (and a store whose metadata vanished) into a :class:`StorageError`
  whose message is one line: what failed, where, the errno's meaning and the free space left.
* :func:`check_free_space` refuses a sweep whose store estimate exceeds the free space before anything is written.
* :func:`store_lock` holds an exclusive ``flock`` on ``STORE.lock`` for the writer's whole run; a second writer
  is refused (:class:`StoreLockedError`). The kernel drops the lock when the process dies, so a killed writer
  never blocks ``--resume``.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import shutil
from pathlib import Path

from hertzian.core.errors import RefusedError


class StorageError(OSError):
    """A write into a store failed (full disk, no permission, read-only or vanished store), or the store would not
    fit. ``str()`` is one line: what failed, where, why, the free space and what to do, with the plan's store
    estimate once ``need`` [bytes] is set (the caller that planned the sweep sets it). Nothing beyond the last
    completed batch is half-written: a batch's completion flag is written last."""

    def __init__(self, code: int, action: str, where: str | Path, *, need: int | None = None):
        super().__init__(code, os.strerror(code), str(where))
        self.action, self.where, self.need = action, str(where), need

    def __str__(self) -> str:
        return fault_line(self.errno, self.action, self.where, self.need)

    def __reduce__(self):  # a Dask worker's error reaches the client whole
        return (type(self), (self.errno, self.action, self.where), {"need": self.need})


class NoRoomError(StorageError):
    """The store's estimate exceeds the free space: the sweep is refused before anything is written."""


class StoreLockedError(RefusedError):
    """Another process is writing into this store (one line)."""


NO_ROOM = "checking free space"
"""``StorageError.action`` of a store that would not fit (refused before anything is written)."""
ADVICE = {
    errno.ENOSPC: "the store needs {need}: free space, then continue with --resume",
    errno.EDQUOT: "the store needs {need}: free quota, then continue with --resume",
    errno.EACCES: "make the store writable, then continue with --resume",
    errno.EPERM: "make the store writable, then continue with --resume",
    errno.EROFS: "remount the filesystem writable or write a new store",
    errno.ENOENT: "the store was removed while the sweep ran; start it again",
}
"""What to do after each storage errno (``{need}``: the plan's store estimate)."""


def free_bytes(path: str | Path) -> int | None:
    """Free bytes on the filesystem holding ``path`` (its nearest existing parent), or None if unknown."""
    path = Path(path).absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        return shutil.disk_usage(path).free
    except OSError:
        return None


def fault_line(code: int, action: str, where: str | Path, need: int | None = None) -> str:
    """One line for a failed store write: ``action`` (what failed) at ``where``, why, free space, what to do."""
    from hertzian.sweeping.planner import format_bytes  # planner imports Warp: only once a write has failed

    free = free_bytes(where)
    free_text = f"; {format_bytes(free)} free there" if free is not None else ""
    need_text = f"about {format_bytes(need)}" if need else "its plan's estimate (hertzian sweep --dry-run)"
    if action == NO_ROOM:
        return f"the store needs {need_text}{free_text}; free space or write the store elsewhere"
    advice = ADVICE.get(code, "fix the store's filesystem, then continue with --resume").format(need=need_text)
    return f"{action} failed at {where}: {os.strerror(code)} (errno {code}){free_text}; {advice}"


@contextlib.contextmanager
def storage_faults(action: str, path: str | Path):
    """Raise :class:`StorageError` (one line) for an ``OSError`` inside: ``action`` (e.g. "writing batch 3")
    failed at the file it names, else at ``path``."""
    try:
        yield
    except StorageError:
        raise
    except OSError as err:
        raise StorageError(err.errno or errno.EIO, action, err.filename or path) from None


def check_store_present(path: str | Path, action: str) -> None:
    """Raise :class:`StorageError` (ENOENT) if the store's root metadata is gone (zarr would recreate the
    directories and write chunks no metadata describes)."""
    if not (Path(path) / "zarr.json").exists():
        raise StorageError(errno.ENOENT, action, path)


def check_free_space(path: str | Path, need: int) -> None:
    """Raise :class:`StorageError` (ENOSPC) if the filesystem of ``path`` has less than ``need`` bytes free."""
    free = free_bytes(path)
    if free is not None and free < need:
        raise NoRoomError(errno.ENOSPC, NO_ROOM, path, need=need)


def lock_path(path: str | Path) -> Path:
    """The lock file of the store at ``path``: ``STORE.lock`` beside it."""
    path = Path(path)
    return path.with_name(path.name + ".lock")


def lock_holder(path: str | Path) -> str | None:
    """Who holds the lock of the store at ``path`` (the holder's line, e.g. 'pid 12 on host'), or None when
    nobody does. Takes no lock."""
    target = lock_path(path)
    try:
        fd = os.open(target, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return os.pread(fd, 200, 0).decode(errors="replace").strip() or "another process"
    except OSError:
        return None
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


@contextlib.contextmanager
def store_lock(path: str | Path):
    """Hold an exclusive lock on the store at ``path`` for the block (raise :class:`StoreLockedError` if another
    process holds it). The lock file is removed on exit; a lock file left by a killed writer holds no lock."""
    target = lock_path(path)
    while True:
        with storage_faults("locking the store", target):
            fd = os.open(target, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "another process"
            os.close(fd)
            raise StoreLockedError(f"{path} is being written by {holder} (lock {target})") from None
        # the file may have been removed (and another made) between open and flock: lock the current one
        if os.path.exists(target) and os.stat(target).st_ino == os.fstat(fd).st_ino:
            break
        os.close(fd)
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {os.uname().nodename}".encode(), 0)
        yield target
    finally:
        with contextlib.suppress(OSError):
            os.unlink(target)
        os.close(fd)


PROJECT = "hertzian"
"""The ``project`` attribute of every store's root group: what ``--overwrite`` checks before it deletes."""


class NotReplaceableError(RefusedError):
    """``--overwrite`` pointed at something that is not a hertzian store (one line: what it is and why)."""


def _protected(path: Path) -> str | None:
    """Why ``path`` (resolved) may never be replaced: the filesystem root, the home folder, the current folder,
    or a folder holding one of those; else None."""
    for name, folder in (("the current folder", Path.cwd()), ("the home folder", Path.home()), ("/", Path("/"))):
        folder = folder.resolve()
        if path == folder:
            return f"is {name}"
        if path in folder.parents:
            return f"holds {name}"
    return None


def _store_entries(path: Path) -> set[str] | None:
    """The top-level names a hertzian store at ``path`` may hold (its root metadata's arrays and groups, the
    metadata files), or None if ``path/zarr.json`` is not a hertzian store's root metadata."""
    import json

    try:
        meta = json.loads((path / "zarr.json").read_text())
    except (OSError, ValueError):
        return None
    attrs = meta.get("attributes", {}) if isinstance(meta, dict) else {}
    provenance = attrs.get("provenance", {}) if isinstance(attrs, dict) else {}
    # stores written before the `project` attribute name the package in their provenance
    named = attrs.get("project") == PROJECT or (isinstance(provenance, dict) and provenance.get("package") == PROJECT)
    if not isinstance(attrs, dict) or not named or "schema_version" not in attrs:
        return None
    consolidated = meta.get("consolidated_metadata") or {}
    members = consolidated.get("metadata", {}) if isinstance(consolidated, dict) else {}
    nodes = {p.name for p in path.iterdir() if (p / "zarr.json").is_file()}  # arrays and groups, consolidated or not
    return {"zarr.json", MANIFEST} | nodes | {str(name).split("/")[0] for name in members}


MANIFEST = "manifest.json"
"""File of a store's root that lists the checksums of its metadata and its chunk files (``integrity``)."""


def check_replaceable(path: str | Path) -> Path:
    """The resolved path of a store that ``--overwrite`` may delete, or :class:`NotReplaceableError` (one line).

    Replaceable: a folder (``.``, ``..`` and symlinks resolved) whose root metadata names this project and its
    schema, holding nothing its metadata does not name; never the filesystem root, the home or the current
    folder, nor a folder that holds one of them."""
    target = Path(path).resolve()
    why = _protected(target)
    if why is None and not target.is_dir():
        why = "is not a folder (a hertzian store is one)"
    entries = None if why else _store_entries(target)
    if why is None and entries is None:
        why = "is not a hertzian store (its zarr.json does not name the project); delete it yourself if you mean to"
    if why is None:
        stray = sorted({p.name for p in target.iterdir()} - entries)
        if stray:
            why = f"holds files a hertzian store does not ({', '.join(stray[:3])}); delete it yourself if you mean to"
    if why:
        raise NotReplaceableError(f"{target} {why}; --overwrite replaces only a store hertzian wrote")
    return target


def resolved_link(path: str | Path) -> Path:
    """``path``, or the folder it links to when it is a symlink (a store is replaced where it lives, and locked
    there whatever name a writer gives it)."""
    path = Path(path)
    return path.resolve() if path.is_symlink() else path


def check_writable_folder(path: str | Path) -> str | None:
    """Why a store or file cannot be written at ``path`` (its folder missing or not writable), else None."""
    import tempfile

    folder = Path(path).absolute().parent
    if not folder.is_dir():
        return "parent directory does not exist"
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        return f"its folder is not writable ({os.strerror(err.errno) if err.errno else err})"
    return None


def check_out(
    out: str | Path,
    *,
    overwrite: bool,
    resume: bool = False,
    hint: str = "resume to continue it or overwrite to replace it",
) -> None:
    """Refuse (:class:`~hertzian.core.errors.OptionError` on ``out``, one line) a store path that exists unless it
    is resumed or replaced; whose folder is missing or cannot be written; or, to be replaced, that is not a hertzian
    store (:func:`check_replaceable`) or that another process is writing (its lock). ``hint``: what to do about a
    path that exists. Nothing is written."""
    from hertzian.core.errors import OptionError

    out = Path(out)
    if out.exists() and not (resume or overwrite):
        try:
            check_replaceable(out)
        except RefusedError as err:  # neither option applies to it: say why, not which option to pass
            raise OptionError("out", str(out), f"exists and {str(err).removeprefix(f'{out.resolve()} ')}") from None
        raise OptionError("out", str(out), f"exists; {hint}")
    why = check_writable_folder(out)
    if why:
        raise OptionError("out", str(out), why)
    if overwrite and (out.exists() or out.is_symlink()):
        try:
            check_replaceable(out)
            with store_lock(resolved_link(out)):  # a writer of it now is refused here, before any work
                pass
        except RefusedError as err:
            raise OptionError("out", str(out), str(err)) from None
