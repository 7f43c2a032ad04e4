"""Where the worlds of a comparison run (:mod:`~evmap.maps.app.compare_runner`): a local pool, a local Dask
cluster, or a Dask scheduler's address; and Ctrl-C held back to the points where stopping is clean.

:func:`executor` yields something with ``submit``, a wait for the first done futures and the number of workers,
and shuts it all down on exit; :func:`interrupts_between_waits` turns Ctrl-C into a KeyboardInterrupt only where
the run checks for it.
"""

from __future__ import annotations

import concurrent.futures
import logging
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from subprocess import DEVNULL
from typing import Any

__all__ = [
    "CONNECT_TIMEOUT",
    "WORKER_DEATH_TIMEOUT",
    "WORKER_STOP_TIMEOUT",
    "executor",
    "interrupts_between_waits",
]

CONNECT_TIMEOUT = 2
"""Seconds to reach a Dask scheduler before giving up (retrying meanwhile): one that is up answers in milliseconds,
one still starting has this long; an unreachable one is refused in a few seconds with the imports."""

WORKER_DEATH_TIMEOUT = 20
"""Seconds a local worker outlives a scheduler it cannot reach (this process killed)."""

WORKER_STOP_TIMEOUT = 3
"""Seconds a local worker is given to stop when told to (SIGTERM), before it is killed: one busy with a world
does not stop before that world is done, and its results are no longer wanted."""


def _ignore_sigint() -> None:
    """In a worker of the ``processes`` pool: leave Ctrl-C to the main process, which shuts the pool down."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _wait_local(futures: list[Any]) -> set[Any]:
    done, _ = concurrent.futures.wait(futures, timeout=0.5, return_when=concurrent.futures.FIRST_COMPLETED)
    return done


def _wait_dask(futures: list[Any]) -> set[Any]:
    from distributed import wait

    try:
        return set(wait(futures, timeout=0.5, return_when="FIRST_COMPLETED").done)
    except TimeoutError:
        return set()


@contextmanager
def interrupts_between_waits() -> Iterator[Callable[[], None]]:
    """Ctrl-C (SIGINT) held back while the executor starts, runs and shuts down, and raised as
    KeyboardInterrupt only where the check it yields is called: between two waits (half a second apart).

    A KeyboardInterrupt raised inside Dask's blocking calls (which wait on its event loop's thread) could leave
    the client or the cluster unable to close: the command hung after Ctrl-C while its workers started. Off the
    main thread, where no signal handler can be set, nothing is held back.
    """
    if threading.current_thread() is not threading.main_thread():
        yield lambda: None
        return
    caught: list[int] = []

    def interrupted() -> None:
        if caught:
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield interrupted
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def executor(scheduler: str | None, workers: int | None) -> Iterator[tuple[Any, Any, int]]:
    """(something with ``submit``, a wait for the first done futures, the number of workers); shut down on exit."""
    n = workers or os.cpu_count() or 1
    if scheduler == "threads":
        with concurrent.futures.ThreadPoolExecutor(n) as pool:
            yield pool, _wait_local, n
    elif scheduler == "processes":
        context = multiprocessing.get_context("spawn")
        pool = concurrent.futures.ProcessPoolExecutor(n, mp_context=context, initializer=_ignore_sigint)
        try:
            yield pool, _wait_local, n
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    elif scheduler is None:
        with _local_cluster(n) as client:
            yield client, _wait_dask, n
    else:
        from distributed import Client

        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ValueError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({reason})") from None
        try:
            yield client, _wait_dask, sum(client.nthreads().values()) or 1
        finally:
            client.close()


@contextmanager
def _local_cluster(n: int) -> Iterator[Any]:
    """A Dask scheduler in this process and ``n`` single-threaded ``dask worker`` processes, a client to them.

    The workers run in their own session: Ctrl-C (sent to the terminal's
    foreground process group) reaches only this process, which then stops them.
    Tasks queue at the scheduler while the workers start.
    """
    import dask
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=0,
        processes=False,
        protocol="tcp",
        host="127.0.0.1",
        scheduler_port=0,
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    command = [
        sys.executable,
        "-m",
        "distributed.cli.dask_worker",
        cluster.scheduler_address,
        "--nthreads=1",
        "--no-nanny",
        "--no-dashboard",
        f"--death-timeout={WORKER_DEATH_TIMEOUT}",
    ]
    # what Dask's nanny sets for its workers (one BLAS thread each), but glibc's MALLOC_TRIM_THRESHOLD_: handing
    # every freed 64 kB back to the system makes the fusion's temporaries page-fault afresh (16 worlds x 6 rules
    # in one process: 90 times the page faults, 0.5 -> 7-8 s of system time, 10-25 % more wall time)
    spawn_environ = dask.config.get("distributed.nanny.pre-spawn-environ")
    env = {**os.environ, **{k: str(v) for k, v in spawn_environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}}
    # and no statistical profiler: a worker samples its stack every 10 ms and keeps a call tree per second for the
    # last 1,000 seconds (benchmarks/bench_memory.py, 1,000 worlds: the largest worker 456 MB with it, 378 MB
    # without; the workers' floors rose 204 -> 299 and 226 -> 304 MB over the run with it, 206 -> 224 and
    # 210 -> 226 MB without)
    env["DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED"] = "False"
    procs: list[subprocess.Popen[bytes]] = []
    try:
        for _ in range(n):
            procs.append(
                subprocess.Popen(
                    command, env=env, stdin=DEVNULL, stdout=DEVNULL, stderr=DEVNULL, start_new_session=True
                )
            )
        with Client(cluster) as client:
            yield client
    finally:
        for proc in procs:
            proc.terminate()
        for proc in procs:
            try:
                proc.wait(timeout=WORKER_STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        cluster.close()
