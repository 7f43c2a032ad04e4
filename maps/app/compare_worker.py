"""Preloaded into every worker process of ``evmap compare``'s local cluster (Dask's ``preload``).

Ctrl-C goes to the whole foreground process group; the workers leave it to the
main process, which shuts them down, so an interrupted comparison prints one line.
"""

from __future__ import annotations

import signal
import threading

__all__ = ["dask_setup"]


def dask_setup(worker: object) -> None:
    """Ignore SIGINT in this worker process (Dask calls this when the worker starts)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
