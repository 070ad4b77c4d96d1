"""A local Ray session that leaves nothing behind: no environment built for its workers, no
session folder once it ends.

``ray.init()`` on this machine, left to itself, writes its session (logs, sockets, spilled
objects) under ``/tmp/ray/session_<date>`` and never removes it; under ``uv run`` it also
builds each session a virtual environment for its workers there (torch included: 7.5 GB a
session). :func:`local_ray` runs the workers on this interpreter, gives Ray a temporary folder
of its own, and removes it when the session ends, whichever way it ends.
"""

from __future__ import annotations

import os
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


@contextmanager
def local_ray(ray: Any, num_cpus: int, **init: Any) -> Iterator[None]:
    """``ray.init(num_cpus=num_cpus, **init)`` on this machine, shut down and its folder
    removed on leaving, also on an exception, Ctrl-C, or SIGTERM/SIGHUP (which raise
    ``KeyboardInterrupt`` named for the signal meanwhile: the command exits 143 or 129). A
    folder left by a session killed outright (SIGKILL) is removed by the next one."""
    _remove_orphaned_sessions()
    temp_dir = tempfile.mkdtemp(prefix=f"{TEMP_PREFIX}{os.getpid()}-", dir=temp_root())
    try:
        with _stop_signals_interrupt():
            try:
                _start(ray, num_cpus=num_cpus, _temp_dir=temp_dir, **init)
                yield
            finally:
                ray.shutdown()
    finally:
        shutil.rmtree(temp_dir, ignore_errors=True)


def _start(ray: Any, **init: Any) -> None:
    with _workers_run_this_interpreter():
        try:
            ray.init(**init)
        except SystemExit as exc:  # a SIGTERM meanwhile: ray.init's own handler exits 15
            if exc.code != signal.SIGTERM:
                raise
            raise KeyboardInterrupt(signal.SIGTERM.name) from exc
    _interrupt_on_stop_signals()  # again: ray.init replaced ours


#: A local session's temporary folder: ``<tmp>/manigraph-ray-<pid of the sweep>-<random>``.
TEMP_PREFIX = "manigraph-ray-"


def temp_root() -> str:
    """Where a local session's folder goes. Ray's sockets live under it and a socket's path
    may not pass 107 bytes: macOS's ``$TMPDIR`` is too long, so Ray itself uses ``/tmp`` there."""
    return "/tmp" if sys.platform == "darwin" else tempfile.gettempdir()


def _remove_orphaned_sessions() -> None:
    """Remove the folders of local sessions whose sweep is gone (killed by SIGKILL, or a
    machine that lost power): nothing else removes them."""
    for folder in Path(temp_root()).glob(f"{TEMP_PREFIX}*"):
        pid = folder.name.removeprefix(TEMP_PREFIX).partition("-")[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


@contextmanager
def _workers_run_this_interpreter() -> Iterator[None]:
    """Keep Ray from building an environment per session for its workers.

    Under ``uv run`` (as the README runs ``manigraph suite``), ``ray.init`` otherwise sets the
    workers' ``py_executable`` to the same ``uv run`` and ships the working directory: each
    session then syncs a fresh virtual environment (torch included: 7.5 GB in
    ``/tmp/ray/session_*/runtime_resources``) before its first task runs, and never removes it.
    A local session's workers run on this machine, where this interpreter's environment
    already holds every package a cell needs, so they run it (Ray's default without ``uv
    run``). Ray reads its switch (``RAY_ENABLE_UV_RUN_RUNTIME_ENV``) once, when imported:
    it is turned off for this ``ray.init`` only, so a later session that joins a cluster keeps
    Ray's default; a user who set the variable keeps their choice.
    """
    from ray._private import ray_constants

    switch = "RAY_ENABLE_UV_RUN_RUNTIME_ENV"
    if switch in os.environ or not hasattr(ray_constants, switch):
        yield
        return
    before = getattr(ray_constants, switch)
    setattr(ray_constants, switch, False)
    try:
        yield
    finally:
        setattr(ray_constants, switch, before)


STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


@contextmanager
def _stop_signals_interrupt() -> Iterator[None]:
    """SIGTERM and SIGHUP raise ``KeyboardInterrupt`` (named for the signal) as Ctrl-C does, so
    the session is shut down and its folder removed (the command's exit status: 143, 129);
    the handlers from before are put back on leaving."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = {number: signal.getsignal(number) for number in STOP_SIGNALS}
    _interrupt_on_stop_signals()
    try:
        yield
    finally:
        for number, handler in before.items():  # None: set outside Python; the default then
            signal.signal(number, signal.SIG_DFL if handler is None else handler)


def _interrupt_on_stop_signals() -> None:
    if threading.current_thread() is threading.main_thread():
        for number in STOP_SIGNALS:
            signal.signal(number, _interrupt)


def _interrupt(number: int, _frame: object) -> None:
    raise KeyboardInterrupt(signal.Signals(number).name)
