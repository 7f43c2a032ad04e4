"""One evmap run at a time per ``--out``: the lock file ``.NAME.evmap-lock`` beside it, holding the process id.

A lock whose process is no longer alive (killed) is taken over. Used by
:func:`evmap.maps.app.staging.claim_output`.
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from evmap.maps.app.output_layout import OutputError

__all__ = ["lock_output", "process_alive"]


def lock_output(out: Path) -> Path:
    """Claim ``out`` with ``.NAME.evmap-lock`` beside it, holding this process id; take over a dead process's.

    The lock appears complete or not at all (a hard link of a written file, which
    fails if the lock exists); a dead process's lock is moved aside and checked
    again before it is dropped, so two runs never both take it over.
    """
    lock = out.parent / f".{out.name}.evmap-lock"
    mine = out.parent / f".{out.name}.evmap-lock.{os.getpid()}.{secrets.token_hex(4)}"  # one per claim, even in threads
    try:
        mine.write_text(f"{os.getpid()}\n")
    except OSError as exc:
        raise OutputError(f"--out {out}: cannot write into {out.parent}: {exc.strerror or exc}") from None
    try:
        for _ in range(5):
            try:
                os.link(mine, lock)
                return lock
            except FileExistsError:
                pass
            pid = _pid_in(lock)
            if pid is not None and process_alive(pid):
                raise OutputError(f"--out {out}: another evmap (process {pid}) is writing it")
            grabbed = out.parent / f".{out.name}.evmap-lock.{os.getpid()}.{secrets.token_hex(4)}.stale"
            try:
                os.rename(lock, grabbed)
            except FileNotFoundError:
                continue
            pid = _pid_in(grabbed)
            if pid is not None and process_alive(pid):  # another run took it over just now: give it back
                try:
                    os.link(grabbed, lock)
                except FileExistsError:
                    pass
                grabbed.unlink()
                raise OutputError(f"--out {out}: another evmap (process {pid}) is writing it")
            grabbed.unlink()
        raise OutputError(f"--out {out}: another evmap is claiming it")
    finally:
        mine.unlink(missing_ok=True)


def _pid_in(lock: Path) -> int | None:
    """The process id a lock file holds; None if it is gone or not a number."""
    try:
        return int(lock.read_text().strip())
    except (OSError, ValueError):
        return None


def process_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (one of another user counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
