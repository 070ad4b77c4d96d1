"""Demonstrations as MCAP: the one writer of ``manigraph demos`` and the demonstration page.

A demonstration is one episode: its start event, then for every step the ``Scene`` the
decision was made on and the ``Action`` (whose ``scene_sequence`` names that scene), then its
end event. ``manigraph train`` pairs each action with its scene
(``manigraph_training.dataset``), so a log written here, a log of ``manigraph demos``
and a run recorded with ``manigraph up --record`` are all training data.

Each demonstration is flushed to disk as a whole once written, so a process killed later
loses none of those before it (``manigraph record --recover`` finalises such a file).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages import Action, EpisodeEvent, Message, Scene

#: How a message's log time is chosen (nanoseconds).
LogTime = Callable[[Message], int]


class SequentialTimes:
    """Log times 1 ms apart from 1 ms on: the same file on every machine (``manigraph demos``,
    whose messages carry a step clock)."""

    def __init__(self) -> None:
        self.now_ns = 0

    def __call__(self, _message: Message) -> int:
        self.now_ns += 1_000_000
        return self.now_ns


def stamp_times(message: Message) -> int:
    """A message's own stamp (wall clock seconds) as its log time: for live demonstrations,
    so a viewer plays them back at the pace they were shown."""
    return int(float(getattr(message, "stamp", 0.0)) * 1e9)


class DemonstrationLog:
    """Append demonstrations to one MCAP file (created, with its folder, on construction)."""

    def __init__(self, path: Path, log_time: LogTime | None = None) -> None:
        self.path = path
        self.log_time: LogTime = log_time or SequentialTimes()
        self._writer = McapLogWriter(path)
        self.demonstrations = 0
        self.decisions = 0

    def write(
        self,
        start: EpisodeEvent | None,
        steps: Iterable[tuple[Scene, Action]],
        end: EpisodeEvent | None,
    ) -> int:
        """One episode: ``start``, each step's scene and action, ``end``; returns its steps."""
        count = 0
        messages: list[Message] = [start] if start is not None else []
        for scene, action in steps:
            if action.scene_sequence != scene.sequence or action.episode_id != scene.episode_id:
                raise ValueError(
                    f"scene_sequence: action {action.decision_id} names scene "
                    f"{action.episode_id} #{action.scene_sequence}, not {scene.episode_id} "
                    f"#{scene.sequence}"
                )
            messages += [scene, action]
            count += 1
        if end is not None:
            messages.append(end)
        for message in messages:
            self._writer.write(message.key_for(), message.encode(), self.log_time(message))
        self._writer.flush()
        self.demonstrations += 1
        self.decisions += count
        return count

    def close(self) -> None:
        self._writer.close()
