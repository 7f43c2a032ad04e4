"""The one way evmap writes an output directory (``--out``): staged, claimed, moved into place, never clobbering.

:func:`claim_output` checks ``--out`` before any work, claims it, and gives a
private staging directory beside it; the command writes its files there; when
the ``with`` block ends normally the staging directory becomes ``--out``,
otherwise it is removed and ``--out`` is left as it was.

Rules
-----
- evmap marks every directory it makes with :data:`MARKER`, a JSON file listing
  what it wrote. ``force`` replaces only a directory whose every entry evmap
  wrote: one it marked, or one holding nothing but the files of the command's
  :class:`Layout` (as evmap wrote before the marker, ``docs/SCENARIO.md``). Anything
  else is refused, naming what is in the way.
- Only files evmap wrote are ever deleted: the replaced directory's files are
  removed by name, and a file that appeared in ``--out`` during the run stops the
  final move (``--out`` is then left as it is, with the file).
- One run at a time per ``--out``: the claim is a lock file
  (``.NAME.evmap-lock`` beside ``--out``) made with ``O_EXCL`` holding the process id;
  a second run is refused. The lock, staging and replaced directories of a process
  that is no longer alive (killed) are cleaned up by the next run into the same
  ``--out``.
- Problems with the output (a file in the way, ``--out`` a symbolic link or the
  current directory or one above it, a read-only or full file system) raise
  :class:`OutputError` (a ``ValueError``: ``evmap: error: ...``, exit 2) before the work.
- Files and directories get ordinary permissions (the umask's), also those
  made by ``mkdtemp``/``mkstemp`` (0700/0600).

The data (marker, layouts, :class:`Staging`, :class:`OutputError`) are in
:mod:`evmap.maps.app.output_layout` (import them from there), the lock in
:mod:`evmap.maps.app.output_lock`.
"""

from __future__ import annotations

import errno
import fnmatch
import glob
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from evmap.maps.app.output_layout import (
    COMPARE_LAYOUT,
    MARKER,
    MIN_FREE_BYTES,
    RUN_LAYOUT,
    Layout,
    OutputError,
    Staging,
)
from evmap.maps.app.output_lock import lock_output, process_alive
from evmap.maps.atomic_file import DIRECTORY_MODE, FILE_MODE, write_atomic

__all__ = ["claim_output", "owned_entries", "write_text_atomic"]


@contextmanager
def claim_output(
    out: str | Path, *, force: bool, layout: Layout, free_bytes: int = MIN_FREE_BYTES
) -> Iterator[Staging]:
    """Check and claim ``out``, give a staging directory, move it into place when the block succeeds.

    Parameters
    ----------
    out : the output directory: absent, an empty directory, or (``force``) one evmap wrote.
    force : replace a non-empty ``out`` that evmap wrote (see the module doc).
    layout : the command's files, for directories written before the marker.
    free_bytes : the free space the run needs on ``out``'s file system.

    Raises
    ------
    OutputError
        Before the block runs, if ``out`` cannot receive the run; after it, if
        something appeared in ``out`` meanwhile (the staged files are then dropped).
    """
    out = Path(out)
    _check_path(out)
    _check_target(out, force, layout)
    parent = out.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"--out {out}: cannot create {parent}: {exc.strerror or exc}") from None
    _check_free(out, free_bytes)
    lock = lock_output(out)
    try:
        _clean_stale(out)
        _check_target(out, force, layout)  # again, now that no other evmap can change it
        try:
            path = Path(tempfile.mkdtemp(prefix=f".{out.name}.evmap-stage-{os.getpid()}-", dir=parent))
        except OSError as exc:
            raise OutputError(f"--out {out}: cannot write into {parent}: {exc.strerror or exc}") from None
        try:
            path.chmod(DIRECTORY_MODE)
            yield Staging(out, path)
            _commit(path, out, force, layout)
        except OSError as exc:  # the disk filled up, or the staged files could not be written, during the run
            if exc.errno not in _FULL and not _inside(exc.filename, path):
                raise
            raise OutputError(f"--out {out}: writing the artefacts failed: {exc.strerror or exc}") from None
        finally:
            shutil.rmtree(path, ignore_errors=True)
    finally:
        lock.unlink(missing_ok=True)


_FULL = frozenset((errno.ENOSPC, errno.EDQUOT, errno.EFBIG))
"""Errors of a file system that cannot take more, whatever file was being written."""


def _inside(filename: object, directory: Path) -> bool:
    """Whether ``filename`` (an OSError's, maybe None) is ``directory`` or under it."""
    if not isinstance(filename, str | os.PathLike):
        return False
    return Path(filename) == directory or directory in Path(filename).parents


def owned_entries(directory: Path, layout: Layout) -> tuple[list[str], list[str]]:
    """The entries of ``directory`` evmap wrote (relative paths, files first) and the others.

    Evmap wrote the files its marker lists whose names are those of artefacts (of any command's layout: a
    marker edited to list a file of the user's does not make it evmap's), or, without a marker, the files of
    ``layout`` when all its required files are there.

    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> d = Path(tmp.name)
    >>> for name in ("report.json", "segments.json", "map.json", "fig2.png", "notes.txt"):
    ...     _ = (d / name).write_text("x")
    >>> owned_entries(d, RUN_LAYOUT)
    (['fig2.png', 'map.json', 'report.json', 'segments.json'], ['notes.txt'])
    >>> tmp.cleanup()
    """
    top = sorted(p.name for p in directory.iterdir())
    marker = directory / MARKER
    if marker.is_file() and not marker.is_symlink():
        try:
            listed = set(json.loads(marker.read_text())["files"])
        except (OSError, ValueError, KeyError, TypeError):
            listed = set()
        mine, others = [], []
        for rel in _walk(directory):
            artefact = any(_named(rel, known) for known in (RUN_LAYOUT, COMPARE_LAYOUT))
            (mine if rel in listed and artefact else others).append(rel)
        return [*mine, MARKER], others
    if not set(layout.required) <= set(top):
        return [], top
    mine, others = [], []
    for name in top:
        entry = directory / name
        if entry.is_file() and not entry.is_symlink() and _named(name, layout):
            mine.append(name)
        elif name in layout.subdirs and entry.is_dir() and not entry.is_symlink():
            inner = sorted(entry.iterdir())
            if all(f.is_file() and not f.is_symlink() and _named(f"{name}/{f.name}", layout) for f in inner):
                mine += [f"{name}/{f.name}" for f in inner] + [f"{name}/"]
            else:
                others.append(name)
        else:
            others.append(name)
    return mine, others


def _named(rel: str, layout: Layout) -> bool:
    """Whether the relative path ``rel`` (``NAME``, ``SUB/NAME`` or ``SUB/``) is named as one of ``layout``'s
    artefacts."""
    sub, _, name = rel.rpartition("/")
    if not sub:
        return name in layout.required or any(fnmatch.fnmatch(name, p) for p in layout.patterns)
    return sub in layout.subdirs and (not name or fnmatch.fnmatch(name, layout.subdirs[sub]))


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file and a rename, with the umask's permissions
    (:func:`evmap.maps.atomic_file.write_atomic`; not synced: the staging directory is renamed into place whole)."""
    write_atomic(path, text.encode("utf-8"), mode=FILE_MODE, sync=False)


# --------------------------------------------------------------------- checks


def _check_path(out: Path) -> None:
    """Refuse an ``--out`` that is a link, the current directory or above it, or under a file."""
    if str(out) in ("", ".", "..") or out.name in ("", ".", ".."):
        raise OutputError(f"--out {out}: name a new directory, not the current directory or one above it")
    if out.is_symlink():
        raise OutputError(f"--out {out}: is a symbolic link; name the directory itself (evmap does not replace links)")
    try:
        cwd = Path.cwd().resolve()
    except OSError:
        cwd = None
    resolved = out.resolve()
    if cwd is not None and (resolved == cwd or resolved in cwd.parents):
        raise OutputError(f"--out {out}: is the current directory or one above it")
    for ancestor in out.absolute().parents:
        if ancestor.exists() or ancestor.is_symlink():
            if not ancestor.is_dir():
                raise OutputError(f"--out {out}: {ancestor} is in the way (a file, not a directory)")
            break


def _check_target(out: Path, force: bool, layout: Layout) -> None:
    """Refuse an ``out`` that is not a directory, or not empty without ``force``, or not evmap's."""
    if not out.exists():
        return
    if not out.is_dir():
        raise OutputError(f"--out {out}: exists and is not a directory")
    entries = sorted(p.name for p in out.iterdir())
    if not entries:
        return
    if not force:
        raise OutputError(f"--out {out}: directory is not empty (use --force to replace a directory evmap wrote)")
    _, others = owned_entries(out, layout)
    if others:
        shown = ", ".join(others[:5]) + (f" and {len(others) - 5} more" if len(others) > 5 else "")
        raise OutputError(f"--out {out}: not a directory evmap wrote, --force refuses to replace it: holds {shown}")


def _check_free(out: Path, free_bytes: int) -> None:
    parent = out.parent
    try:
        stat = os.statvfs(parent)
    except OSError as exc:
        raise OutputError(f"--out {out}: cannot inspect {parent}: {exc.strerror or exc}") from None
    if not os.access(parent, os.W_OK) or stat.f_flag & os.ST_RDONLY:
        raise OutputError(f"--out {out}: {parent} is not writable (read-only file system or no permission)")
    free = stat.f_bavail * stat.f_frsize
    if free < free_bytes:
        raise OutputError(f"--out {out}: only {free // 2**20} MiB free on its file system, need {free_bytes // 2**20}")


# --------------------------------------------------------------------- clean, commit


def _clean_stale(out: Path) -> None:
    """Remove the staging and replaced directories that dead evmap processes left beside ``out``.

    A replaced directory whose run died before its own took its place (``out`` is missing: killed between
    the two renames of ``--force``) is put back as ``out``, as if that run had never started.
    """
    for kind in ("stage", "old"):
        for path in sorted(out.parent.glob(f".{glob.escape(out.name)}.evmap-{kind}-*")):
            pid = path.name.removeprefix(f".{out.name}.evmap-{kind}-").split("-")[0]
            if not pid.isdigit() or process_alive(int(pid)) or not path.is_dir() or path.is_symlink():
                continue
            if kind == "stage":
                shutil.rmtree(path, ignore_errors=True)  # wholly evmap's: nobody else writes there
            elif not os.path.lexists(out):
                os.rename(path, out)
            else:
                _remove_owned(path, COMPARE_LAYOUT if (path / "summary.csv").exists() else RUN_LAYOUT)
    for path in out.parent.glob(f".{glob.escape(out.name)}.evmap-lock.*"):  # a half-taken lock of a killed run
        pid = path.name.removeprefix(f".{out.name}.evmap-lock.").split(".")[0]
        if pid.isdigit() and not process_alive(int(pid)):
            path.unlink(missing_ok=True)


def _commit(staging: Path, out: Path, force: bool, layout: Layout) -> None:
    """Mark the staged files, fix their modes, and rename the staging directory to ``out``."""
    files = _walk(staging)
    for rel in files:
        target = staging / rel.rstrip("/")
        target.chmod(DIRECTORY_MODE if rel.endswith("/") else FILE_MODE)
    write_text_atomic(staging / MARKER, json.dumps({"command": layout.command, "files": files}, indent=1) + "\n")
    old = None
    if out.exists() and any(out.iterdir()):
        _check_target(out, force, layout)  # a file that appeared during the run stops us here
        old = out.parent / f".{out.name}.evmap-old-{os.getpid()}"
        os.rename(out, old)
    try:
        os.rename(staging, out)  # fails if out appeared, or holds anything, meanwhile
    except OSError as exc:
        if old is not None:
            os.rename(old, out)
        if exc.errno in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR, errno.EISDIR):
            raise OutputError(f"--out {out}: something appeared there during the run; left it as it is") from None
        raise
    if old is not None:
        left = _remove_owned(old, layout)
        if left:
            print(f"evmap: warning: {old} keeps what appeared in the replaced directory: {left}", file=sys.stderr)


def _remove_owned(directory: Path, layout: Layout) -> list[str]:
    """Delete the entries of ``directory`` evmap wrote, then the directory if empty; return the others."""
    mine, others = owned_entries(directory, layout)
    for rel in sorted(mine, key=lambda r: (r.endswith("/"), -r.count("/"))):
        path = directory / rel.rstrip("/")
        try:
            path.rmdir() if rel.endswith("/") else path.unlink()
        except OSError:
            others.append(rel)
    if not others:
        try:
            directory.rmdir()
        except OSError:  # something appeared meanwhile
            others = sorted(p.name for p in directory.iterdir())
    return others


def _walk(directory: Path) -> list[str]:
    """Every file (``a/b``) and sub-directory (``a/``) under ``directory``, relative, sorted; the marker excluded."""
    found = []
    for root, dirs, names in os.walk(directory):
        rel = Path(root).relative_to(directory)
        found += [f"{(rel / d).as_posix()}/" for d in dirs]
        found += [(rel / n).as_posix() for n in names if not (rel == Path(".") and n == MARKER)]
    return sorted(found)
