"""A mutational fuzzer for volume: cheap hostile payloads (~10-50 us each) mutated from a pool
of valid objects that Hypothesis draws once (:func:`seed_objects`), for floods of hundreds of
thousands (``manigraph_testkit.flood``, the soaks). Hypothesis' own strategies, slower and
shrinking, are :mod:`manigraph_testkit.fuzzing`'s; this module needs the same dev dependency
group."""

from __future__ import annotations

import json
import math
from typing import Any

from manigraph_shared.messages import Message
from manigraph_testkit.fuzzing import json_bytes, valid_objects


def seed_objects(cls: type[Message], count: int, seed: int = 0) -> list[dict[str, Any]]:
    """``count`` valid JSON objects of ``cls`` drawn by Hypothesis (deterministic per seed)."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hypothesis_seed

    drawn: list[dict[str, Any]] = []

    @hypothesis_seed(seed)
    @settings(
        max_examples=count,
        database=None,
        deadline=None,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    @given(valid_objects(cls))
    def draw(obj: dict[str, Any]) -> None:
        drawn.append(obj)

    draw()
    return drawn


class Mutator:
    """Cheap hostile payloads (~10-50 us each) from a pool of valid objects, for floods of
    hundreds of thousands: the same families as ``hostile_payloads``, plus byte flips,
    nesting bombs and type confusion. ``valid_share`` of the payloads are left valid."""

    def __init__(self, pool: list[dict[str, Any]], seed: int = 0, valid_share: float = 0.05):
        import random

        if not pool:
            raise ValueError("pool: needs at least one valid object")
        self.pool = pool
        self.valid_share = valid_share
        self.rng = random.Random(seed)
        self._ops = [
            self._random_bytes,
            self._replace_field,
            self._replace_field,
            self._drop_field,
            self._extra_field,
            self._truncate,
            self._flip_bytes,
            self._nesting_bomb,
            self._wrong_shape,
            self._replace_nested,
        ]

    def __call__(self) -> bytes:
        obj = self.rng.choice(self.pool)
        if self.rng.random() < self.valid_share:
            return json_bytes(obj)
        return self.rng.choice(self._ops)(obj)

    # random JSON values, with the extremes validation must survive
    def value(self, depth: int = 0) -> Any:
        r = self.rng
        kind = r.randrange(12 if depth < 3 else 9)
        if kind == 0:
            return None
        if kind == 1:
            return r.random() < 0.5
        if kind == 2:
            return r.choice([0, -1, 1, 2**31, -(2**63), 2**64, 10**30, r.randrange(-1000, 1000)])
        if kind == 3:
            return r.choice(
                [math.nan, math.inf, -math.inf, 1e308, -1e-308, -0.0, r.uniform(-1e3, 1e3)]
            )
        if kind == 4:
            return "".join(chr(r.randrange(0, 0x2FF)) for _ in range(r.randrange(0, 40)))
        if kind == 5:
            return "x" * r.choice([0, 64, 65, 1024, 70_000])
        if kind == 6:
            return r.choice(
                ["", "ok", "failed", "block", "latest", "../../etc", "\u0000", "é" * 70]
            )
        if kind == 7:
            return r.uniform(-200, 200)
        if kind == 8:
            return r.randrange(-5, 300)
        if kind in (9, 10):
            return [self.value(depth + 1) for _ in range(r.randrange(0, 5))]
        return {self.value_key(): self.value(depth + 1) for _ in range(r.randrange(0, 4))}

    def value_key(self) -> str:
        return self.rng.choice(["id", "x", "y", "z", "w", "", "objects", "state", "\u2603"])

    def _random_bytes(self, _obj: dict[str, Any]) -> bytes:
        return self.rng.randbytes(self.rng.randrange(0, 512))

    def _replace_field(self, obj: dict[str, Any]) -> bytes:
        keys = list(obj) or ["x"]
        return json_bytes({**obj, self.rng.choice(keys): self.value()})

    def _replace_nested(self, obj: dict[str, Any]) -> bytes:
        copy = json.loads(json.dumps(obj))
        node: Any = copy
        for _ in range(4):  # walk down a few levels, then replace one member there
            if isinstance(node, dict) and node:
                key = self.rng.choice(list(node))
                if self.rng.random() < 0.5 or not isinstance(node[key], (dict, list)):
                    node[key] = self.value()
                    break
                node = node[key]
            elif isinstance(node, list) and node:
                index = self.rng.randrange(len(node))
                if not isinstance(node[index], (dict, list)):
                    node[index] = self.value()
                    break
                node = node[index]
            else:
                break
        return json_bytes(copy)

    def _drop_field(self, obj: dict[str, Any]) -> bytes:
        if not obj:
            return b"{}"
        drop = self.rng.choice(list(obj))
        return json_bytes({k: v for k, v in obj.items() if k != drop})

    def _extra_field(self, obj: dict[str, Any]) -> bytes:
        return json_bytes({**obj, self.value_key() + "_extra": self.value()})

    def _truncate(self, obj: dict[str, Any]) -> bytes:
        data = json_bytes(obj)
        return data[: self.rng.randrange(0, max(1, len(data)))]

    def _flip_bytes(self, obj: dict[str, Any]) -> bytes:
        data = bytearray(json_bytes(obj))
        for _ in range(self.rng.randrange(1, 8)):
            data[self.rng.randrange(len(data))] = self.rng.randrange(256)
        return bytes(data)

    def _nesting_bomb(self, _obj: dict[str, Any]) -> bytes:
        depth = self.rng.choice([100, 1000, 10_000, 100_000])
        return b"[" * depth + b"]" * depth if self.rng.random() < 0.5 else b'{"a":' * depth

    def _wrong_shape(self, obj: dict[str, Any]) -> bytes:
        return self.rng.choice(
            [json_bytes([obj]), json_bytes(list(obj.values())), b"null", b'"{}"', b"1e999"]
        )
