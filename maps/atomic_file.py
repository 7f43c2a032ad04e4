"""Files written atomically: a reader sees the old file or the new one, never a part of it.

One writer for every file evmap writes whole: ``map.json`` (:mod:`evmap.maps.map_file`), the
ROS map pair (:mod:`evmap.maps.occupancy`) and the run artefacts (:mod:`evmap.maps.app.staging`).
A new file gets ordinary permissions, the umask's (:data:`FILE_MODE`), not those of the
temporary file it was written to (0600); a file written over keeps its own, and a path that
is a symbolic link writes the file it points to (the link stays).

>>> import pathlib, tempfile
>>> with tempfile.TemporaryDirectory() as tmp:
...     path = pathlib.Path(tmp) / "a.txt"
...     write_atomic(path, b"one")
...     new = path.stat().st_mode & 0o777
...     path.chmod(0o640)
...     write_atomic(path, b"two", sync=False)
...     path.read_bytes(), new == FILE_MODE, oct(path.stat().st_mode & 0o777), sorted(p.name for p in path.parent.iterdir())
(b'two', True, '0o640', ['a.txt'])
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from pathlib import Path

__all__ = ["DIRECTORY_MODE", "FILE_MODE", "write_atomic"]


def _umask() -> int:
    """The process's umask, read without changing it where ``/proc`` tells it."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_UMASK = _umask()  # read once, at import: os.umask() is process-wide and not thread-safe

FILE_MODE = 0o666 & ~_UMASK
"""The permissions of a new file: what ``open`` would give it under the process's umask."""

DIRECTORY_MODE = 0o777 & ~_UMASK
"""The permissions of a new directory: what ``mkdir`` would give it under the process's umask."""


def write_atomic(path: str | Path, data: bytes, *, mode: int | None = None, sync: bool = True) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory and a rename.

    ``sync``: the data reach the disk before the rename (a crash leaves the old file or
    the new one). ``mode``: the file's permissions; by default those of the file written over,
    or :data:`FILE_MODE` for a new one.
    """
    path = Path(os.path.realpath(path))  # through a symbolic link: the link stays, what it points to is written
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "a directory: name the file to write", str(path))
    if mode is None:
        try:
            mode = stat.S_IMODE(path.stat().st_mode)
        except OSError:  # no file there yet (or none that can be read): a new file's permissions
            mode = FILE_MODE
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            if sync:
                f.flush()
                os.fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
