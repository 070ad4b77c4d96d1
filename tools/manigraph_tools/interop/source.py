"""The log an exporter reads: checked before anything is written, read with manigraph's own
MCAP reader, and counted so a truncated file says where it stopped.

:func:`check_paths` refuses what cannot be exported (a missing file, a file that is not MCAP,
an output folder that already holds something) with a :class:`ConfigError` naming the problem.
:class:`SourceLog` yields the contract's messages in file order; a file whose writer was
killed yields every message up to its last complete chunk (``read_log``), and
:meth:`SourceLog.stopped` then says after how many messages and at which log time.

A log recorded from robot cells (``manigraph record``: every cell, each on its own channels,
``manigraph/cell-1/world/scene``; ``record --cell NAME``: that cell's) is exported one cell at a
time: :func:`choose_cell` takes the only cell the log holds, or the one asked for, and refuses
a log of several cells when none is chosen, naming the cells it holds. Heartbeats
(``ServiceStatus``) do not make a cell present: the recorder of every cell sends its own in the
default cell.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from manigraph_shared.cells import cell_of, check_cell, default_key
from manigraph_shared.errors import ConfigError, MessageError
from manigraph_shared.mcap_log import MCAP_MAGIC, LoggedMessage, is_finalised, read_log
from manigraph_shared.messages import Message, ServiceStatus, message_type_for_key

#: How a summary and a refusal name the default cell (its keys have no cell segment).
DEFAULT_CELL = "the default cell"


def check_paths(log: Path, out: Path) -> None:
    """Refuse a log that cannot be read as MCAP and an output that is not new or empty."""
    if not log.exists():
        raise ConfigError("log", f"{log} does not exist")
    if not log.is_file():
        raise ConfigError("log", f"{log} is not a file")
    try:
        with log.open("rb") as stream:
            head = stream.read(len(MCAP_MAGIC))
    except OSError as exc:
        raise ConfigError("log", f"cannot read {log}: {exc.strerror}") from None
    if head != MCAP_MAGIC:
        raise ConfigError("log", f"{log} is not an MCAP file (it does not start with MCAP's magic)")
    if out.exists() and not out.is_dir():
        raise ConfigError("output", f"{out} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()):
        raise ConfigError("output", f"{out} exists and is not empty (give a new or empty folder)")


def cells_in(log: Path) -> list[str | None]:
    """The robot cells whose messages ``log`` holds (``None``: the default cell), in order of
    appearance; heartbeats alone do not count (see the module's doc)."""
    seen: dict[str | None, None] = {}
    for item in read_log(log):
        message_type = message_type_for_key(default_key(item.topic))
        if message_type is not None and message_type is not ServiceStatus:
            seen.setdefault(cell_of(item.topic))
    return list(seen)


def cell_label(cell: str | None) -> str:
    return DEFAULT_CELL if cell is None else cell


def choose_cell(log: Path, asked: str | None) -> str | None:
    """The cell of ``log`` to export: ``asked`` (``""``: the default cell) if the log holds
    it, else the log's only cell; a ``ConfigError`` (field ``cell``) naming the cells present
    otherwise."""
    present = cells_in(log)
    names = ", ".join(cell_label(cell) for cell in present) or "none"
    if asked is not None:
        cell = check_cell(asked) if asked else None
        if cell not in present:
            raise ConfigError("cell", f"{log} holds no {cell_label(cell)} (cells present: {names})")
        return cell
    if len(present) > 1:
        raise ConfigError(
            "cell",
            f"{log} holds several robot cells ({names}): choose one with --cell NAME "
            "(--cell '' for the default cell); each cell exports on its own",
        )
    return present[0] if present else None


@dataclass
class SourceLog:
    """The contract messages of ``path`` in robot cell ``cell`` (``None``: the default cell),
    decoded, with counts of what was read; other cells' messages are read past, uncounted."""

    path: Path
    cell: str | None = None
    messages_read: int = 0
    last_log_time_ns: int | None = None
    #: Per source topic: messages read, and those that did not validate (skipped).
    read_per_topic: Counter[str] = field(default_factory=Counter)
    invalid_per_topic: Counter[str] = field(default_factory=Counter)
    _types: dict[str, type[Message] | None] = field(default_factory=dict)

    def messages(
        self, wanted: tuple[type[Message], ...]
    ) -> Iterator[tuple[LoggedMessage, Message]]:
        """Each logged message of a ``wanted`` type, decoded, in file order; every message
        (wanted or not) is counted."""
        for item in read_log(self.path):
            self.messages_read += 1
            self.last_log_time_ns = item.log_time_ns
            if cell_of(item.topic) != self.cell:
                continue
            self.read_per_topic[item.topic] += 1
            message_type = self.type_of(item.topic)
            if message_type is None or not issubclass(message_type, wanted):
                continue
            try:
                yield item, message_type.decode(item.data, item.topic)
            except MessageError:
                self.invalid_per_topic[item.topic] += 1

    def type_of(self, topic: str) -> type[Message] | None:
        if topic not in self._types:
            self._types[topic] = message_type_for_key(default_key(topic))
        return self._types[topic]

    def stopped(self) -> dict[str, object] | None:
        """Where reading stopped, if the file was cut short (its writer never finished it);
        None for a finalised file."""
        if is_finalised(self.path):
            return None
        return {
            "reason": "the log is truncated (its writer did not finish it): exported every "
            "message up to its last complete chunk",
            "messages_read": self.messages_read,
            "last_log_time_ns": self.last_log_time_ns,
        }
