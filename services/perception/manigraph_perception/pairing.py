"""Parts of frames (an RGB-D frame's colour image and depth image) waiting for the rest of the
same ``sequence``, in buffers whose bound holds whatever the sequence numbers do.

A camera sends both halves within milliseconds, so one or two wait at a time. Halves whose
partner never comes (a dropped sample, or a forger's: 1,500 depth images with descending
sequences once held 600 MB, since only halves *older* than the newest were let go) are let
go by count and by age:

* at most ``limit`` wait; past it the lowest sequence goes first (a camera's sequences
  grow, so the lowest is the stalest: descending forged ones push out each other, not the
  camera's newest);
* none waits longer than ``max_age`` seconds after it arrived (a forged sequence far above
  the camera's would otherwise hold its place until the camera caught up).

At most ``limit`` x ``MAX_IMAGE_BYTES`` (8 x 700 kB) per kind is held.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Generic, Protocol, TypeVar

T = TypeVar("T")

#: Halves of one kind (colour or depth) waiting at most, and for at most how long (s).
UNPAIRED_LIMIT = 8
UNPAIRED_MAX_AGE = 2.0


class HalfBuffer(Generic[T]):
    """Messages by sequence, at most ``limit`` of them and none older than ``max_age``
    seconds (None: no age bound, e.g. a recording replayed at once)."""

    def __init__(
        self,
        limit: int = UNPAIRED_LIMIT,
        max_age: float | None = UNPAIRED_MAX_AGE,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if limit < 1:
            raise ValueError(f"limit: must be >= 1, not {limit}")
        self.limit = limit
        self.max_age = max_age
        self.clock = clock
        self._held: dict[int, tuple[float, T]] = {}
        #: Halves let go without their partner (count or age), over the buffer's life.
        self.dropped = 0

    def __len__(self) -> int:
        return len(self._held)

    def hold(self, sequence: int, message: T) -> None:
        """Keep ``message`` until its partner comes (a repeated sequence replaces)."""
        now = self.clock()
        self._expire(now)
        self._held[sequence] = (now, message)
        while len(self._held) > self.limit:
            del self._held[min(self._held)]
            self.dropped += 1

    def pop(self, sequence: int) -> T | None:
        """The half of ``sequence`` if it waits (and is not too old), no longer held."""
        self._expire(self.clock())
        entry = self._held.pop(sequence, None)
        return None if entry is None else entry[1]

    def drop_older(self, sequence: int) -> None:
        """Let go every half older than ``sequence`` (its frame is complete: theirs is past)."""
        for old in [s for s in self._held if s < sequence]:
            del self._held[old]
            self.dropped += 1

    def _expire(self, now: float) -> None:
        if self.max_age is None:
            return
        for old in [s for s, (at, _) in self._held.items() if now - at > self.max_age]:
            del self._held[old]
            self.dropped += 1


class Sequenced(Protocol):
    @property
    def sequence(self) -> int: ...


P = TypeVar("P", bound=Sequenced)


class FrameAssembler(Generic[P]):
    """A frame's named parts joined by ``sequence`` in any order, each part waiting in a
    :class:`HalfBuffer` of its own; a frame of one part is whole at once."""

    def __init__(self, parts: Iterable[str]) -> None:
        names = list(parts)
        if not names:
            raise ValueError("a frame has at least one part")
        self._waiting: dict[str, HalfBuffer[P]] = {name: HalfBuffer() for name in names}

    @property
    def dropped(self) -> int:
        """Parts let go without the rest of their frame, over the assembler's life."""
        return sum(buffer.dropped for buffer in self._waiting.values())

    def add(self, part: str, message: P) -> dict[str, P] | None:
        """The whole frame ``message`` completes (its parts by name), or None: it waits."""
        found = {part: message}
        for name, buffer in self._waiting.items():
            if name == part:
                continue
            other = buffer.pop(message.sequence)
            if other is not None:
                found[name] = other
        if len(found) == len(self._waiting):
            return found
        for name, held in found.items():  # not whole yet: everything found waits again
            self._waiting[name].hold(message.sequence, held)
        return None
