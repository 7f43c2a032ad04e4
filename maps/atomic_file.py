"""Files written atomically: a reader sees the old file or the new one, never a part of it.

One writer for every file evmap writes whole: ``map.json`` (:mod:`evmap.maps.map_file`), the
ROS map pair (:mod:`evmap.maps.occupancy`) and the run artefacts (:mod:`evmap.maps.app.staging`).

>>> import pathlib, tempfile
>>> with tempfile.TemporaryDirectory() as tmp:
...     write_atomic(pathlib.Path(tmp) / "a.txt", b"one")
...     write_atomic(pathlib.Path(tmp) / "a.txt", b"two", mode=0o644, sync=False)
...     path = pathlib.Path(tmp) / "a.txt"
...     path.read_bytes(), oct(path.stat().st_mode & 0o777), sorted(p.name for p in path.parent.iterdir())
(b'two', '0o644', ['a.txt'])
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["write_atomic"]


def write_atomic(path: str | Path, data: bytes, *, mode: int | None = None, sync: bool = True) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory and a rename.

    ``sync``: the data reach the disk before the rename (a crash leaves the old file or
    the new one). ``mode``: the file's permissions; by default those of a temporary file (0600).
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            if sync:
                f.flush()
                os.fsync(f.fileno())
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
