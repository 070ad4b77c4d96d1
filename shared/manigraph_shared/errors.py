"""The exception tree every manigraph library raises.

Libraries raise these; services catch them, log them and publish a ``ServiceStatus`` so the
failure also lands in the MCAP log. Nothing here logs or prints.
"""

from __future__ import annotations


class ManigraphError(Exception):
    """Base class for every error manigraph raises on purpose."""


#: Exit status of a command refused for its configuration (sysexits' EX_CONFIG): restarting
#: the process cannot help, so the supervisor does not.
CONFIG_EXIT_CODE = 78


class ConfigError(ManigraphError, ValueError):
    """A configuration value is missing or out of range; ``field`` names it."""

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
    (as opposed to no answer at all, a plain :class:`BusError`)."""


class LogError(ManigraphError):
    """An MCAP log could not be read or written."""


class TaskError(ManigraphError, ValueError):
    """A task description (name, task file, parameters) is invalid."""


class SkillError(ManigraphError):
    """A skill could not be executed; ``reason`` is the short machine-readable cause."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason
        self.detail = detail


class PolicyError(ManigraphError):
    """A policy could not be loaded or could not decide."""
