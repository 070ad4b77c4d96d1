"""Run a sweep's cells as Ray tasks, or one after another in this process.

A sweep (``manigraph suite``, ``manigraph select``, the seed study that ``suite --seeds``
runs) is a list of :class:`Job`\\ s: independent trainings and evaluations, one per
(architecture, seed, task cell), each a plain function of its arguments that seeds itself.
A job may take an earlier job's result (:class:`Needs`), as an evaluation takes the
checkpoint its training wrote. Jobs pass bytes, not paths, so a cluster needs no shared disk.

:func:`run_jobs` runs them on Ray (local by default: ``ray.init()`` on this machine, one CPU
per task, ``workers`` CPUs; or the cluster at ``ray_address``), or sequentially in this
process, the reference. The results come back in the jobs' order whichever finished first,
so both give the same figures for the same seeds. A failing job is reported under its name;
the others' results are kept, and a job that needs a failed one is not run.

Ray is imported here only when a sweep runs on it, so ``manigraph --help`` does not pay for it.
"""

from __future__ import annotations

import argparse
import logging
import os
import socket
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from manigraph_lab.ray_local import local_ray
from manigraph_shared.errors import ConfigError, ManigraphError
from manigraph_shared.progress import Progress

#: How long the address check waits for a cluster's head to answer.
PROBE_SECONDS = 3.0

#: An argument of at least this size, shared by several jobs, is put in Ray's object store once.
SHIP_ONCE_BYTES = 64 * 1024


@dataclass(frozen=True)
class Needs:
    """An argument of a job: the result of the earlier job named ``name``."""

    name: str


@dataclass(frozen=True)
class Job:
    """One cell of a sweep: ``fn(*args)``, named for progress lines and errors."""

    name: str
    fn: Callable[..., Any]
    args: tuple[Any, ...] = ()

    @property
    def needs(self) -> list[str]:
        return [a.name for a in self.args if isinstance(a, Needs)]


@dataclass(frozen=True)
class Outcome:
    """A job's result, or what went wrong (``error``: the exception's type and message)."""

    value: Any = None
    error: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


class SweepError(ManigraphError):
    """Some cells of a sweep failed; ``failures`` maps each one's name to its error. The
    others' results were kept (and written, where the sweep writes any)."""

    def __init__(self, failures: dict[str, str], total: int) -> None:
        lines = "\n".join(f"  {name}: {error}" for name, error in failures.items())
        super().__init__(f"{len(failures)} of {total} cells failed:\n{lines}")
        self.failures = failures


@dataclass(frozen=True)
class SweepOptions:
    """Where a sweep's cells run.

    Args:
        workers: cells at once on this machine (Ray's ``num_cpus``); None: every core.
        ray_address: a running Ray cluster to join (``host:port``, ``ray://host:port`` or
            ``auto``) instead of starting one here; ``workers`` is then the cluster's to choose.
        ray: False runs the cells one after another in this process (the reference).
        threads: torch threads of a cell run sequentially; a Ray task uses 1 when several
            run at once (intra-op threads that wait for each other on a shared CPU are slow).
    """

    workers: int | None = None
    ray_address: str | None = None
    ray: bool = True
    threads: int = 1

    def __post_init__(self) -> None:
        if self.workers is not None and self.workers < 1:
            raise ConfigError("workers", f"must be >= 1, got {self.workers}")
        if self.threads < 1:
            raise ConfigError("threads", f"must be >= 1, got {self.threads}")
        if self.ray_address is not None:
            if not self.ray:
                raise ConfigError("ray_address", "cannot be combined with --no-ray")
            _check_address_syntax(self.ray_address)

    @property
    def worker_count(self) -> int:
        return self.workers if self.workers is not None else os.cpu_count() or 1

    @property
    def task_threads(self) -> int:
        """Torch threads inside one Ray task."""
        several = self.ray_address is not None or self.worker_count > 1
        return 1 if several else self.threads

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> SweepOptions:
        """The command line's choice: ``--no-ray``, or ``--workers 1`` without a cluster, runs
        sequentially in this process; anything else on Ray."""
        local_one = args.workers == 1 and args.ray_address is None
        return cls(
            workers=args.workers,
            ray_address=args.ray_address,
            ray=not (args.no_ray or local_one),
            threads=getattr(args, "threads", 1),
        )


def add_sweep_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("sweep (Ray)")
    group.add_argument(
        "--workers",
        type=int,
        default=None,
        help="cells at once on this machine, one Ray task each (default: every core); "
        "1: sequentially in this process",
    )
    group.add_argument(
        "--ray-address",
        default=None,
        metavar="ADDR",
        help="join the Ray cluster at ADDR (host:port, ray://host:port or auto) instead of "
        "starting Ray on this machine",
    )
    group.add_argument(
        "--no-ray", action="store_true", help="run the cells one after another in this process"
    )


def _check_address_syntax(address: str) -> None:
    if address == "auto":
        return
    rest = address.removeprefix("ray://")
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(
            "ray_address",
            f"'{address}' is not host:port, ray://host:port or auto (e.g. 10.0.0.5:6379)",
        )


def check_reachable(options: SweepOptions) -> None:
    """Refuse ``options.ray_address`` before a sweep spends time on anything else."""
    if options.ray and options.ray_address is not None:
        _probe(options.ray_address)


def _probe(address: str) -> None:
    """Refuse an address where nothing answers, in seconds rather than after Ray's retries."""
    if address == "auto":
        return
    host, _, port = address.removeprefix("ray://").rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=PROBE_SECONDS):
            pass
    except OSError as exc:
        raise ConfigError(
            "ray_address",
            f"no Ray cluster answers at {address} ({exc}); start one with `ray start --head` "
            "there, or leave --ray-address out to run on this machine",
        ) from exc


@contextmanager
def ray_session(options: SweepOptions) -> Iterator[Any]:
    """The ``ray`` module, connected: a session this process already holds (kept open), the
    cluster at ``options.ray_address``, or a local one of ``options.workers`` CPUs.

    A local session leaves nothing behind (:func:`manigraph_lab.ray_local.local_ray`).
    """
    if options.ray_address is not None:
        _probe(options.ray_address)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # no network calls from a sweep
    import ray

    if ray.is_initialized():
        yield ray
        return
    # The cells print nothing; what goes wrong comes back as their exceptions.
    common: dict[str, Any] = {"log_to_driver": False, "logging_level": logging.WARNING}
    if options.ray_address is not None:
        try:
            ray.init(address=options.ray_address, **common)
        except (ConnectionError, TimeoutError) as exc:
            raise ConfigError(
                "ray_address", f"could not join {options.ray_address}: {exc}"
            ) from exc
        try:
            yield ray
        finally:
            ray.shutdown()
        return
    with local_ray(ray, options.worker_count, include_dashboard=False, **common):
        yield ray


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _call_in_task(fn: Callable[..., Any], threads: int, *args: Any) -> Any:
    """A job's body inside a Ray worker: torch threads set first, as the worker is shared."""
    import torch

    torch.set_num_threads(threads)
    return fn(*args)


def run_jobs(
    jobs: Sequence[Job],
    options: SweepOptions,
    progress: Progress | None = None,
    on_done: Callable[[Job, Outcome], None] | None = None,
) -> list[Outcome]:
    """Every job's outcome, in the order of ``jobs``. ``progress`` advances once per job as it
    finishes; ``on_done`` sees each job's outcome then (in the order they finish)."""
    names = [job.name for job in jobs]
    if len(set(names)) != len(names):
        raise ValueError(f"job names repeat: {sorted(n for n in names if names.count(n) > 1)}")
    for index, job in enumerate(jobs):
        unknown = [n for n in job.needs if n not in names[:index]]
        if unknown:
            raise ValueError(f"job {job.name} needs {unknown}, not an earlier job")
    if options.ray:
        return _run_on_ray(jobs, options, progress, on_done)
    return _run_here(jobs, progress, on_done)


def _unmet(job: Job, outcomes: dict[str, Outcome]) -> Outcome | None:
    failed = [n for n in job.needs if not outcomes[n].ok]
    return Outcome(error=f"not run: needs {failed[0]}, which failed") if failed else None


def _finished(
    job: Job, outcome: Outcome, progress: Progress | None, on_done: Callable[..., None] | None
) -> None:
    if on_done is not None:
        on_done(job, outcome)
    if progress is not None:
        progress.update()


def _run_here(
    jobs: Sequence[Job], progress: Progress | None, on_done: Callable[..., None] | None
) -> list[Outcome]:
    outcomes: dict[str, Outcome] = {}
    for job in jobs:
        if progress is not None:
            progress.status(job.name)
        outcome = _unmet(job, outcomes)
        if outcome is None:
            args = [outcomes[a.name].value if isinstance(a, Needs) else a for a in job.args]
            try:
                outcome = Outcome(job.fn(*args))
            except Exception as exc:  # a failing cell must not lose the others
                outcome = Outcome(error=_describe(exc))
        outcomes[job.name] = outcome
        _finished(job, outcome, progress, on_done)
    return [outcomes[job.name] for job in jobs]


def _run_on_ray(
    jobs: Sequence[Job],
    options: SweepOptions,
    progress: Progress | None,
    on_done: Callable[..., None] | None,
) -> list[Outcome]:
    with ray_session(options) as ray:
        from ray.exceptions import RayError, RayTaskError

        # One CPU per task; no retry of a cell that raised (the default retries only crashes).
        task = ray.remote(num_cpus=1)(_call_in_task)
        refs: dict[str, Any] = {}
        shipped: dict[int, Any] = {}  # id of a large argument -> its copy in the object store

        def ship(arg: Any) -> Any:
            """A large argument several jobs share (a checkpoint, the demonstrations) goes
            to the object store once, not once per job."""
            if not isinstance(arg, bytes) or len(arg) < SHIP_ONCE_BYTES:
                return arg
            if id(arg) not in shipped:
                shipped[id(arg)] = ray.put(arg)
            return shipped[id(arg)]

        for job in jobs:
            args = [refs[a.name] if isinstance(a, Needs) else ship(a) for a in job.args]
            refs[job.name] = task.remote(job.fn, options.task_threads, *args)
        by_ref = {ref: job for job, ref in zip(jobs, refs.values(), strict=True)}
        outcomes: dict[str, Outcome] = {}
        pending = list(refs.values())
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                job = by_ref[ref]
                try:
                    outcome = Outcome(ray.get(ref))
                except RayTaskError as exc:
                    cause = exc.cause if isinstance(exc.cause, BaseException) else exc
                    outcome = Outcome(error=_describe(cause))
                except RayError as exc:  # a worker or node died
                    outcome = Outcome(error=_describe(exc))
                # A job whose input failed raised that input's error; name the input instead,
                # as the sequential run does (an input finishes before the jobs that need it).
                if all(n in outcomes for n in job.needs):
                    outcome = _unmet(job, outcomes) or outcome
                outcomes[job.name] = outcome
                if progress is not None:
                    progress.status(job.name)
                _finished(job, outcome, progress, on_done)
    return [outcomes[job.name] for job in jobs]
