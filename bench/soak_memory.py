"""The soak's memory rule for its long fuzz: a leak goes on growing, a warm-up step stops.

Comparing the RSS before the fuzz with the RSS after it cannot tell the two apart: a service
that grows once to the working set of a stack that has seen every kind of payload (the sim
88 → 106 MiB while three keys were fuzzed, skills 75 → 95 on the first key, both flat for
the rest) breaks a 20 % bound as surely as one that leaks. So the fuzz is judged on its
trend instead:

* while each key (message type) is fuzzed, every service's RSS is read once a second and
  the key's **floor** kept (the lowest reading): memory that leaked is never given back, so
  a leak raises the floor, while a service's transient peaks (a burst in its inbox, a
  planning step of an episode running meanwhile) do not;
* over the **last** :data:`LAST_KEYS` keys the floor's slope is taken against the payloads
  sent (Theil-Sen: the median of the slopes between every two keys, so one odd key moves it
  little), in MiB per 100,000 payloads;
* a service **holds** if that slope, carried over all the fuzz's payloads, adds at most
  :data:`RSS_TOLERANCE` (20 %) of its RSS before the fuzz: a service that grew steadily
  to +20 % still breaks; one that stepped and then stayed flat does not.

The other checks (floods, explain bomb, task file) last a minute or two, too short for a
trend; they keep the bound on before → after.
"""

from __future__ import annotations

import statistics
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import TracebackType

#: The share a service's RSS may grow (after → before, or the fuzz's trend carried over it).
RSS_TOLERANCE = 0.20
#: Keys (message types) whose RSS floors the fuzz's trend is taken over: the last 8 of 18.
LAST_KEYS = 8
PER = 100_000  # slopes are given per this many payloads


@dataclass(frozen=True)
class KeyReading:
    """One fuzzed key: the payloads sent so far in the fuzz (all keys, this one included)
    and each service's RSS floor while it was fuzzed, MiB."""

    key: str
    sent: int
    floor: dict[str, float]


@dataclass(frozen=True)
class Trend:
    """A service's RSS trend over the last keys of a fuzz."""

    service: str
    slope: float  # MiB per PER payloads
    carried: float  # MiB: the slope over every payload of the fuzz
    limit: float  # MiB: RSS_TOLERANCE of the RSS before the fuzz
    keys: int

    @property
    def held(self) -> bool:
        return self.carried <= self.limit

    def describe(self) -> str:
        return (
            f"{self.service} {self.slope:+.2f} MiB per {PER:,} over the last {self.keys} keys "
            f"({self.carried:+.0f} MiB over the fuzz, limit {self.limit:.0f})"
        )


def theil_sen(xs: Sequence[float], ys: Sequence[float]) -> float:
    """The median of the slopes between every two points with different x."""
    slopes = [
        (ys[j] - ys[i]) / (xs[j] - xs[i])
        for i in range(len(xs))
        for j in range(i + 1, len(xs))
        if xs[j] != xs[i]
    ]
    return statistics.median(slopes) if slopes else 0.0


def fuzz_trends(
    readings: Sequence[KeyReading],
    before: dict[str, float],
    last: int = LAST_KEYS,
    tolerance: float = RSS_TOLERANCE,
) -> list[Trend]:
    """Every service's trend over the last ``last`` keys of ``readings`` (at least two), judged
    against its RSS ``before`` the fuzz. A service not read before (gone) is not judged here:
    a dead service breaks the check on its own."""
    if len(readings) < 2:
        raise ValueError(f"readings: a trend needs two keys or more, got {len(readings)}")
    window = readings[-last:]
    total = readings[-1].sent
    trends = []
    for service, baseline in before.items():
        if baseline <= 0:
            continue
        xs = [r.sent for r in window]
        ys = [r.floor[service] for r in window]
        per_payload = theil_sen(xs, ys)
        trends.append(
            Trend(
                service=service,
                slope=per_payload * PER,
                carried=per_payload * total,
                limit=tolerance * baseline,
                keys=len(window),
            )
        )
    return trends


@dataclass
class RssFloor:
    """The lowest RSS of every service while a ``with`` block runs, read every ``period`` s
    in a thread and once more at its end (also kept: ``last``, that final reading)."""

    read: Callable[[], dict[str, float]]
    period: float = 1.0
    floor: dict[str, float] = field(default_factory=dict)
    last: dict[str, float] = field(default_factory=dict)
    _stop: threading.Event = field(default_factory=threading.Event)
    _thread: threading.Thread | None = None

    def _take(self) -> None:
        self.last = self.read()
        for service, rss in self.last.items():
            if rss > 0:
                self.floor[service] = min(rss, self.floor.get(service, rss))

    def _loop(self) -> None:
        while not self._stop.wait(self.period):
            self._take()

    def __enter__(self) -> RssFloor:
        self._thread = threading.Thread(target=self._loop, name="rss-floor", daemon=True)
        self._thread.start()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        self._take()
