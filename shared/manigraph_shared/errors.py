"""The exception tree every manigraph library raises, and the exit status of each kind.

Libraries raise these; services catch them, log them and publish a ``ServiceStatus`` so the
failure also lands in the MCAP log. Nothing here logs or prints.

A ``manigraph`` command that fails prints one line, ``manigraph <command>: <why>``, on stderr
and exits with the status of the kind of failure (docs/running.md, "Exit codes"):

====  ==============  =========================================================================
code  kind            when
====  ==============  =========================================================================
0     success         the command did what it was asked
1     runtime         it could not be done now: no stack answers, a service went away, the
                      emergency stop is engaged, the stack stopped, a reset ran out of time
                      (:class:`BusError`, :class:`SkillError`, :class:`RequestFailed`, any
                      other :class:`ManigraphError`). Trying again later may work.
2     usage           the command line does not parse: an unknown flag, a missing or
                      malformed argument (argparse's own status; it prints the subcommand's
                      usage).
78    configuration   what was asked for is refused: a value out of range (:class:`ConfigError`),
                      a task or task file (:class:`TaskError`), a checkpoint or policy that
                      cannot serve (:class:`PolicyError`), a log that cannot be read
                      (:class:`LogError`), a request the stack refused (:class:`RequestRefused`),
                      a path that cannot be read or written (an ``OSError`` such as ENOENT).
                      The same input fails again: ``up``'s supervisor does not restart it.
130   interrupted     Ctrl-C
====  ==============  =========================================================================
"""

from __future__ import annotations

from typing import ClassVar

#: Exit status of a command that could not be done now (the default of every error).
RUNTIME_EXIT_CODE = 1
#: Exit status of a command line that does not parse (argparse's).
USAGE_EXIT_CODE = 2
#: Exit status of a command refused for its configuration (sysexits' EX_CONFIG): restarting
#: the process cannot help, so the supervisor does not.
CONFIG_EXIT_CODE = 78
#: Exit status after Ctrl-C (128 + SIGINT).
INTERRUPTED_EXIT_CODE = 130


class ManigraphError(Exception):
    """Base class for every error manigraph raises on purpose; ``exit_code``: the status a
    command failing with it exits with (see the table above)."""

    exit_code: ClassVar[int] = RUNTIME_EXIT_CODE


class ConfigError(ManigraphError, ValueError):
    """A configuration value is missing or out of range; ``field`` names it."""

    exit_code: ClassVar[int] = CONFIG_EXIT_CODE

    def __init__(self, field: str, problem: str) -> None:
        super().__init__(f"{field}: {problem}")
        self.field = field
        self.problem = problem


class MessageError(ManigraphError, ValueError):
    """A payload could not be decoded into its declared message type.

    ``fields`` lists every offending field as a dotted path (``objects.2.position.x``), so the
    error names what was wrong, not just that something was.
    """

    def __init__(self, message_type: str, key: str, problems: list[tuple[str, str]]) -> None:
        self.message_type = message_type
        self.key = key
        self.problems = problems
        details = "; ".join(f"{field}: {why}" for field, why in problems)
        super().__init__(f"bad {message_type} on '{key}': {details}")

    @property
    def fields(self) -> list[str]:
        return [field for field, _ in self.problems]


class BusError(ManigraphError):
    """The Zenoh bus could not be reached or answered with an error."""


class RequestRefused(BusError):
    """A queryable answered a request with an error reply: the request itself was refused
    (as opposed to no answer at all, a plain :class:`BusError`), so asking again fails again."""

    exit_code: ClassVar[int] = CONFIG_EXIT_CODE


class RequestFailed(RequestRefused):
    """A queryable answered with an error of the runtime kind: it could not do it now (a
    reset that ran out of time, an engaged emergency stop, a bug), so asking again later may
    work. A :class:`RequestRefused` still, for whoever tells refusals apart by their text."""

    exit_code: ClassVar[int] = RUNTIME_EXIT_CODE


class LogError(ManigraphError):
    """An MCAP log (or a dataset) given to a command could not be read or written."""

    exit_code: ClassVar[int] = CONFIG_EXIT_CODE


class TaskError(ManigraphError, ValueError):
    """A task description (name, task file, parameters) is invalid."""

    exit_code: ClassVar[int] = CONFIG_EXIT_CODE


class DrawRefused(TaskError):
    """One seed's draw of a valid task file leaves a required goal unfillable (by the file, or
    by the judge's rules): that seed is refused, the others still run (``refused_seeds``)."""

    #: Words every such refusal says, so a client that gets it as a bus reply's text knows it.
    MARK: ClassVar[str] = "for this seed"


class SkillError(ManigraphError):
    """A skill could not be executed; ``reason`` is the short machine-readable cause."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason
        self.detail = detail


class PolicyError(ManigraphError):
    """A policy could not be loaded, or cannot decide on the scenes it is given (a policy
    for other tasks)."""

    exit_code: ClassVar[int] = CONFIG_EXIT_CODE
