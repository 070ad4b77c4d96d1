"""Hostile load for a running stack: fuzzed payloads on every key, scene floods, RSS readings.

Used by the reliability suite and the soaks (``bench/soak.py``, ``bench/soak_flood.py``);
needs the dev dependency group (Hypothesis seeds the fuzzer's pools).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.errors import MessageError
from manigraph_shared.messages import (
    Delivery,
    GoalCategory,
    Message,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_testkit.fuzzing import message_types
from manigraph_testkit.mutation_fuzzer import Mutator, seed_objects


def concrete_key(cls: type[Message]) -> str:
    """The key a forger would publish ``cls`` on (placeholders filled with ``fuzz``)."""
    return re.sub(r"\{[a-z_]+\}", "fuzz", cls.key)


@dataclass
class FuzzCount:
    sent: int = 0
    seconds: float = 0.0
    valid_skipped: int = 0


def _is_valid(cls: type[Message], payload: bytes) -> bool:
    try:
        cls.decode(payload)
    except MessageError:
        return False
    return True


def fuzz_stack(
    bus: Bus,
    per_type: int,
    seed: int = 0,
    pool_size: int = 40,
    valid_share: float = 0.05,
    types: list[type[Message]] | None = None,
    query_share: float = 0.2,
    invalid_only: bool = True,
) -> dict[str, FuzzCount]:
    """Publish ``per_type`` fuzzed payloads on every type's key (queries: ``query_share`` of
    that, sent as query payloads without waiting for the answers).

    With ``invalid_only`` every payload sent fails validation (a draw that happens to be a
    valid message is counted in ``valid_skipped`` and not sent): malformed input must cost a
    service nothing, while what a *valid* forged message may do is the access-control and
    in-service checks' business.
    """
    counts: dict[str, FuzzCount] = {}
    for index, cls in enumerate(types or message_types()):
        mutate = Mutator(seed_objects(cls, pool_size, seed + index), seed + index, valid_share)
        key = concrete_key(cls)
        count = FuzzCount()
        started = time.perf_counter()
        total = per_type if cls.delivery is not Delivery.QUERY else int(per_type * query_share)
        while count.sent < max(1, total):
            payload = mutate()
            if invalid_only and _is_valid(cls, payload):
                count.valid_skipped += 1
                continue
            if cls.delivery is Delivery.QUERY:
                bus.session.get(key, payload=payload, timeout=2.0)
            else:
                bus.put_raw(key, payload, cls.delivery)
            count.sent += 1
        count.seconds = time.perf_counter() - started
        counts[cls.__name__] = count
    return counts


def flood_scene(sequence: int, blocks: int = 4) -> Scene:
    """A valid scene of a forged episode: what a flood of valid scenes repeats."""
    return Scene(
        episode_id="flood",
        stamp=time.time(),
        sequence=sequence,
        objects=[
            SceneObject(
                id=f"block_{i}",
                category=ObjectCategory.BLOCK,
                position=Vector3(x=0.5, y=-0.2 + 0.05 * i, z=0.02),
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
            for i in range(blocks)
        ],
        goals=[
            SceneGoal(
                id=f"goal_{i}", category=GoalCategory.BLOCK, position=Vector3(x=0.4, y=0.2, z=0.02)
            )
            for i in range(blocks)
        ],
    )


def flood_scenes(bus: Bus, seconds: float, rate: float, valid: bool) -> int:
    """Publish scenes (valid, or NaN-poisoned) at ``rate`` per second for ``seconds``."""
    template = flood_scene(0).encode()
    poisoned = template.replace(b'"x":0.5', b'"x":NaN', 1)
    sent = 0
    started = time.perf_counter()
    while (elapsed := time.perf_counter() - started) < seconds:
        due = int(elapsed * rate) + 1
        while sent < due:
            if valid:  # a new sequence each time, without building a model per sample
                payload = template.replace(b'"sequence":0', b'"sequence":%d' % sent, 1)
            else:
                payload = poisoned
            bus.put_raw(Scene.key, payload, Delivery.LATEST)
            sent += 1
        time.sleep(0.001)
    return sent


def rss_mb(pid: int) -> float:
    """Resident set size of process ``pid`` in MiB (0 if it is gone)."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0.0
    match = re.search(r"VmRSS:\s+(\d+) kB", text)
    return int(match.group(1)) / 1024 if match else 0.0
