"""Which episodes a run asks for and what it reports: the flags ``manigraph run``, ``up`` and
``eval`` share (:class:`EpisodeOptions`), the plan they make (:class:`EpisodePlan`: one seeded
``EpisodeRequest`` per episode), a ``--task-file`` read and named, each episode's
:class:`EpisodeResult` and the run's summary (:func:`summarize`). Running the plan against a
stack is :mod:`manigraph_tools.episodes`'."""

from __future__ import annotations

import re
import stat
import statistics
import tomllib
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest
from manigraph_shared.options import Interval, Options, option
from manigraph_shared.printable import printable
from manigraph_tools.family import family_of_task

AT_LEAST_ONE = Interval(1, None)
#: An episode's reason when the sim refused its seed's draw (``DrawRefused``): not run.
SEED_REFUSED = "seed_refused"
#: ``EpisodeRequest.blocks`` as nobody set it: a task file's request sends this, not its count.
UNSET_BLOCKS = 4
#: The services an episode needs.
RUN_SERVICES = ("sim", "planner", "skills")


@dataclass(frozen=True)
class EpisodeOptions(Options):
    """Which episodes to run: the flags ``manigraph run``, ``up`` and ``eval`` share
    (``add_option_arguments(parser, EpisodeOptions)``)."""

    task: str = option("stack", help="task name")
    task_file: Path | None = option(None, help="your own TOML layout (docs/running.md)")
    rules: Path | None = option(
        None,
        help="with --task-file: rules only the teacher and the judge know (docs/task-files.md): "
        "success and rule violations are judged by them; the Scene never shows them",
    )
    blocks: int = option(4, help="blocks per stack K", within=AT_LEAST_ONE)
    stacks: int = option(1, help="number of stacks s", within=AT_LEAST_ONE)
    objects: int | None = option(
        None,
        help="objects, for a task sized by them (unset: its family's default; docs/families.md)",
        within=AT_LEAST_ONE,
    )
    preference: str | None = option(
        None, help="how the objects are to be placed, for a task whose family reads it (its docs)"
    )
    episodes: int | None = option(
        None,
        help="run N episodes, then exit (up without it: keep the stack running)",
        within=AT_LEAST_ONE,
    )
    seed: int = option(0, help="seed of the first episode", within=Interval(0, None))
    timeout: float = option(
        120.0, help="seconds per episode", within=Interval(0, None, low_open=True)
    )
    stall_timeout: float = option(
        30.0,
        help="fail an episode after this long without a decision or skill status",
        within=Interval(0, None, low_open=True),
        unit="s",
    )
    json: bool = option(False, help="print only the JSON summary (stdout, one line)")

    def task_text(self) -> str | None:
        """The task file's text (validated later, by the sim), or None without one."""
        return read_task_file(self.task_file)

    def rules_text(self) -> str | None:
        """The rules file's text (checked later, by the sim, against the task file), or None
        without one; rules without a task file are refused."""
        if self.rules is not None and self.task_file is None:
            raise ConfigError("rules", "rules judge a task file's goals; give --task-file too")
        return read_task_file(self.rules, field="rules")

    def label(self) -> str:
        """What episodes are named after: the task file's name (its stem, as an identifier),
        else the task and K."""
        family = family_of_task(self.task) if self.task_file is None else None
        if family is not None:  # sized its own way: named after its count
            count = getattr(self, family.sized_by[0])
            return f"{self.task}-{count}" if count else self.task
        if self.task_file is None:
            return f"{self.task}-{self.blocks}"
        return re.sub(r"[^A-Za-z0-9_.\-]+", "-", self.task_file.stem)[:40] or "task-file"

    def plan(self, episodes: int, run_id: str = "run") -> EpisodePlan:
        task_file = self.task_text()
        about = describe_task_file(task_file) if task_file is not None else None
        return EpisodePlan(
            task="file" if task_file is not None else self.task,
            task_file=task_file,
            rules=self.rules_text(),
            task_file_name=self.label() if task_file is not None else None,
            name=about[0] if about else None,
            blocks=about[1] if about else self.blocks,
            stacks=self.stacks,
            objects=self.objects,
            preference=self.preference,
            episodes=episodes,
            seed=self.seed,
            timeout=self.timeout,
            stall_timeout=self.stall_timeout,
            run_id=run_id,
        )


@dataclass(frozen=True)
class EpisodeResult:
    episode_id: str
    seed: int
    success: bool
    goals_filled: int
    goals_total: int
    steps: int
    #: Wall-clock seconds from the reset request to the end event.
    seconds: float
    reason: str
    #: Simulated seconds, from a world with a clock (physics); None otherwise.
    sim_seconds: float | None = None
    #: Goals holding an object they do not accept at the end.
    goals_wrong_object: int = 0
    #: Placements into a goal the rules do not accept (with rules), even if later undone.
    rule_violations: int = 0
    #: The skills' refusals of the episode's decisions, by reason.
    refusals: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class EpisodePlan:
    task: str
    blocks: int
    stacks: int
    episodes: int
    seed: int
    timeout: float = 120.0
    run_id: str = "run"
    task_file: str | None = None  # TOML text of a user layout
    rules: str | None = None  # TOML text of rules only the judge (and teacher) know
    task_file_name: str | None = None  # what the file is called (its stem)
    name: str | None = None  # the file's own ``name``
    #: No decision and no skill status of the episode for this long fails it.
    stall_timeout: float = 30.0
    #: Longest wait for every service to be back before an episode.
    recover_timeout: float = 60.0
    services: tuple[str, ...] = RUN_SERVICES
    objects: int | None = None  # a family's count (manigraph_tools.family)
    preference: str | None = None  # a family's option

    def describe(self) -> str:
        """What the episodes are, for progress lines: for a family sized its own way, its
        count and options (each as asked: left out, the sim's default), else the task (or
        file) and K."""
        family = family_of_task(self.task)
        if family is not None:
            count, *options = (getattr(self, name) for name in family.sized_by)
            asked = [f"{count} {family.counted}" if count else "", *(o or "" for o in options)]
            return " ".join([self.task, *filter(None, asked)])
        return f"{self.task_file_name or self.task} K={self.blocks}"

    def request(self, index: int) -> EpisodeRequest:
        seed = self.seed + index
        # A task file says its own blocks: ``blocks`` here only names it (up to 256), and
        # the request's field (K of a registered task, 1-64) is left as nobody set it.
        file = self.task_file is not None
        return EpisodeRequest(
            episode_id=f"{self.run_id}-{index:04d}",
            task="file" if file else self.task,
            blocks=UNSET_BLOCKS if file else self.blocks,
            stacks=self.stacks,
            objects=self.objects,
            options={"preference": self.preference} if self.preference is not None else {},
            seed=seed,
            task_file=self.task_file,
            rules=self.rules,
        )


def describe_task_file(text: str) -> tuple[str | None, int] | None:
    """The file's ``name`` and its number of blocks (spares included), read leniently for
    naming episodes and summaries: the sim validates the file, and refuses it naming the
    field. None when the text is not TOML (or nested too deeply for Python to read)."""
    try:
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):
        return None
    objects = data.get("objects")
    blocks = (
        sum(isinstance(o, dict) and o.get("category") == "block" for o in objects)
        if isinstance(objects, list)
        else 0
    )
    name = data.get("name")
    # A file without blocks is still the sim's to refuse, naming the field: K stays >= 1 here.
    return (name if isinstance(name, str) else None, max(blocks, 1))


def read_task_file(path: Path | None, field: str = "task-file") -> str | None:
    """The text of a ``--task-file`` (its layout is validated later, by the sim), or None
    without one. What is not a regular file (``/dev/zero``, a pipe, a directory) is refused by
    name, and a file too long to travel in a reset request is refused having read at most the
    limit: its size first, then never more than the limit's bytes and one. ``field`` names
    the flag in a refusal (``rules`` for a ``--rules`` file, read the same way)."""
    if path is None:
        return None
    limit = _task_file_limit()
    most = 4 * limit  # bytes: UTF-8 spends at most 4 on a character
    try:
        if not stat.S_ISREG(path.stat().st_mode):
            raise ConfigError(field, f"{_shown(path)} is not a regular file")
        with path.open("rb") as file:
            data = file.read(most + 1)
    except OSError as exc:
        raise ConfigError(field, f"cannot read {_shown(path)}: {exc.strerror}") from None
    if len(data) > most:
        raise ConfigError(
            "task-file",
            f"{_shown(path)} has over {most:,} bytes; a task file holds at most "
            f"{limit:,} characters",
        )
    try:
        text = data.decode()
    except UnicodeDecodeError:
        raise ConfigError(field, f"cannot read {_shown(path)}: not UTF-8 text") from None
    if len(text) > limit:
        raise ConfigError(
            "task-file",
            f"{_shown(path)} has {len(text):,} characters; a task file holds at most {limit:,}",
        )
    return text


def _shown(path: Path) -> str:
    return printable(str(path))


def _task_file_limit() -> int:
    """``EpisodeRequest.task_file``'s max_length, from the contract itself."""
    return EpisodeRequest.max_length("task_file")


def episode_size(task: str, sizes: object) -> dict[str, object]:
    """What ``task``'s episodes hold, read from ``sizes`` (a plan, ``manigraph eval``'s spec:
    anything with those fields): its family's own sizes (its count and options, as asked),
    or blocks and stacks."""
    family = family_of_task(task)
    if family is not None:
        return {name: getattr(sizes, name) for name in family.sized_by}
    return {name: getattr(sizes, name) for name in ("blocks", "stacks")}


def summarize(plan: EpisodePlan, results: list[EpisodeResult]) -> dict[str, object]:
    count = len(results)
    named = {"task_file": plan.task_file_name, "name": plan.name} if plan.task_file else {}
    return {
        "task": plan.task,
        **named,
        **episode_size(plan.task, plan),
        "seed": plan.seed,
        "episodes": count,
        "success_rate": sum(r.success for r in results) / count if count else 0.0,
        "goals_filled_rate": (
            statistics.fmean(r.goals_filled / max(r.goals_total, 1) for r in results)
            if count
            else 0.0
        ),
        "mean_steps": statistics.fmean(r.steps for r in results) if count else 0.0,
        # Goals left holding an object they do not accept, over all episodes' ends.
        "wrong_object": sum(r.goals_wrong_object for r in results),
        **_judged(plan, results),
        "refusals": summed_refusals(r.refusals for r in results),
        "mean_seconds": statistics.fmean(r.seconds for r in results) if count else 0.0,
        **_simulated(results),
        "results": [asdict(r) for r in results],
    }


def summed_refusals(counts: Iterable[Mapping[str, int]]) -> dict[str, int]:
    """Refusals by reason over episodes, most first (``{reason: count}``)."""
    total: Counter[str] = Counter()
    for count in counts:
        total.update(count)
    return dict(total.most_common())


def _judged(plan: EpisodePlan, results: list[EpisodeResult]) -> dict[str, object]:
    """Placements the rules refused (with ``--rules``), and the seeds whose draw was refused
    (each with why) while the others ran."""
    refused = [
        {"seed": r.seed, "reason": r.reason.removeprefix(SEED_REFUSED + ": ")}
        for r in results
        if r.reason.startswith(SEED_REFUSED)
    ]
    return {
        **({"rule_violations": sum(r.rule_violations for r in results)} if plan.rules else {}),
        **({"refused_seeds": refused} if refused else {}),
    }


def _simulated(results: list[EpisodeResult]) -> dict[str, float]:
    """Mean simulated seconds per episode and the real-time factor (simulated over wall time:
    1 in real time, ~30 flat out), over the episodes whose world has a clock."""
    timed = [r for r in results if r.sim_seconds is not None]
    if not timed:
        return {}
    simulated = sum(r.sim_seconds or 0.0 for r in timed)
    wall = sum(r.seconds for r in timed)
    return {
        "mean_sim_seconds": round(simulated / len(timed), 3),
        "realtime_factor": round(simulated / wall, 3) if wall > 0 else 0.0,
    }
