"""Hypothesis strategies for every message type: valid messages and hostile payloads.

Used by the reliability suite (``tests/reliability/``) and the soak (``bench/soak.py``); it
needs the workspace's dev dependency group (``hypothesis``), which no service image installs.

Valid messages are drawn from each type's own JSON Schema (the one written into MCAP), then
*repaired* where a model-level check relates fields (a unit quaternion, one joint position per
joint name, a failed status with a reason, ...) so that nearly every draw is valid and the
rest are filtered out. Hostile payloads are arbitrary bytes, arbitrary JSON, valid messages
with one field replaced, removed or added, and valid encodings cut short.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any, cast

from hypothesis import strategies as st

from manigraph_shared.errors import MessageError
from manigraph_shared.messages import Message

#: Lists in generated messages are kept short: validation, not volume, is what is tested.
MAX_ITEMS = 4
MAX_TEXT = 80

JSON_LEAVES = (
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.floats()  # NaN and inf too: json.dumps writes them as NaN / Infinity tokens
    | st.text(max_size=40)
)
JSON_VALUES = st.recursive(
    JSON_LEAVES,
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=12), children, max_size=4)
    ),
    max_leaves=12,
)


def message_types() -> list[type[Message]]:
    """Every registered message type, in a stable order."""
    return [Message.registry[name] for name in sorted(Message.registry)]


# --- valid messages ---------------------------------------------------------------------------
def valid_objects(cls: type[Message]) -> st.SearchStrategy[dict[str, Any]]:
    """JSON objects that validate as ``cls`` (most draws; see ``valid_messages``)."""
    schema = cls.model_json_schema()
    return _from_schema(schema, schema.get("$defs", {})).map(lambda obj: _repair(cls, obj))


def valid_messages(cls: type[Message]) -> st.SearchStrategy[Message]:
    def build(obj: dict[str, Any]) -> Message | None:
        try:
            return cls.decode(json.dumps(obj).encode())
        except MessageError:
            return None

    built = valid_objects(cls).map(build).filter(lambda m: m is not None)
    return cast("st.SearchStrategy[Message]", built)


def _from_schema(schema: dict[str, Any], defs: dict[str, Any]) -> st.SearchStrategy[Any]:
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        if name == "Quaternion":
            return _unit_quaternions()
        return st.deferred(lambda: _from_schema(defs[name], defs))
    if "const" in schema:
        return st.just(schema["const"])
    if "enum" in schema:
        return st.sampled_from(schema["enum"])
    if "anyOf" in schema:
        return st.one_of([_from_schema(option, defs) for option in schema["anyOf"]])
    kind = schema.get("type")
    if kind == "string":
        if "pattern" in schema:
            return _pattern_text(schema["pattern"])
        return st.text(
            min_size=schema.get("minLength", 0),
            max_size=min(schema.get("maxLength", MAX_TEXT), MAX_TEXT),
        )
    if kind == "integer":
        return st.integers(
            min_value=schema.get("minimum", -(2**53)), max_value=schema.get("maximum", 2**53)
        )
    if kind == "number":
        return st.floats(
            min_value=schema.get("minimum", schema.get("exclusiveMinimum", -1e9)),
            max_value=schema.get("maximum", schema.get("exclusiveMaximum", 1e9)),
            exclude_min="exclusiveMinimum" in schema,
            exclude_max="exclusiveMaximum" in schema,
            allow_nan=False,
            allow_infinity=False,
        )
    if kind == "boolean":
        return st.booleans()
    if kind == "null":
        return st.none()
    if kind == "array":
        if "prefixItems" in schema:
            return st.tuples(*(_from_schema(item, defs) for item in schema["prefixItems"])).map(
                list
            )
        low = schema.get("minItems", 0)
        return st.lists(
            _from_schema(schema.get("items", {}), defs),
            min_size=low,
            max_size=max(low, min(schema.get("maxItems", MAX_ITEMS), MAX_ITEMS)),
        )
    if kind == "object":
        return _objects(schema, defs)
    return JSON_VALUES


def _pattern_text(pattern: str) -> st.SearchStrategy[str]:
    """``^[class]{m,n}$`` (every pattern of the contract) as plain text, which is far faster to
    draw than ``from_regex``; anything else through ``from_regex``."""
    simple = re.fullmatch(r"\^\[([^\]]+)\]\{(\d+),(\d+)\}\$", pattern)
    if simple is None:
        return st.from_regex(pattern, fullmatch=True)
    members, low, high = simple.group(1), int(simple.group(2)), int(simple.group(3))
    alphabet = "".join(
        chr(c) for c in range(32, 127) if re.fullmatch(f"[{members}]", chr(c)) is not None
    )
    return st.text(alphabet=alphabet, min_size=low, max_size=high)


def _objects(schema: dict[str, Any], defs: dict[str, Any]) -> st.SearchStrategy[dict[str, Any]]:
    properties = schema.get("properties", {})
    if not properties:
        extra = schema.get("additionalProperties")
        values = _from_schema(extra, defs) if isinstance(extra, dict) else JSON_VALUES
        return st.dictionaries(st.text(min_size=1, max_size=12), values, max_size=MAX_ITEMS)
    required = set(schema.get("required", []))
    fields = {
        name: _from_schema(sub, defs) if name in required else st.none() | _from_schema(sub, defs)
        for name, sub in properties.items()
    }
    # st.none() for an optional field means "leave it out" (its default applies).
    return st.fixed_dictionaries(fields).map(
        lambda obj: {k: v for k, v in obj.items() if k in required or v is not None}
    )


def _unit_quaternions() -> st.SearchStrategy[dict[str, float]]:
    parts = st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 4)

    def normalise(q: tuple[float, float, float, float]) -> dict[str, float]:
        norm = math.sqrt(sum(v * v for v in q))
        if norm < 1e-3:
            return {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
        return dict(zip("xyzw", (v / norm for v in q), strict=True))

    return parts.map(normalise)


def _repair(cls: type[Message], obj: dict[str, Any]) -> dict[str, Any]:
    """Make fields agree where a model-level check relates them."""
    name = cls.__name__
    if name == "SkillStatus" and obj.get("state") == "failed" and not obj.get("reason"):
        obj["reason"] = "fuzzed"
    elif name == "EpisodeEvent":
        obj["goals_filled"] = min(obj["goals_filled"], obj["goals_total"])
        if obj["phase"] == "end" and obj.get("success") is None:
            obj["success"] = False
    elif name == "ExplainRequest" and obj.get("decision_id") and obj.get("scene"):
        obj.pop("scene")
    elif name == "Explanation":
        features = obj.get("features")
        if isinstance(features, dict):
            obj["features"] = {k: min(max(float(v), 0.0), 1.0) for k, v in features.items()}
    elif name in ("JointState", "JointTrajectoryResult", "JointTrajectoryCommand"):
        _repair_joints(obj)
    if name == "Scene":
        _repair_scene(obj)
    elif name == "ExplainRequest" and isinstance(obj.get("scene"), dict):
        _repair_scene(obj["scene"])
    return obj


def _repair_joints(obj: dict[str, Any]) -> None:
    names: list[str] | None = None
    if "joint_names" in obj:
        names = [n[:64] or "j" for n in obj["joint_names"]] or ["j0"]
        obj["joint_names"] = names

    def fit(values: list[float]) -> list[float]:
        values = [math.remainder(v, 2 * math.pi) for v in values]
        if names is None:
            return values
        return values[: len(names)] + [0.0] * (len(names) - len(values[: len(names)]))

    if "positions" in obj:
        obj["positions"] = fit(obj["positions"])
    if "points" in obj:
        t = 0.0
        for point in obj["points"]:
            point["positions"] = fit(point["positions"])
            t += 0.01
            point["time_from_start"] = t


def _repair_scene(scene: dict[str, Any]) -> None:
    for index, item in enumerate(scene.get("objects", [])):
        item["id"] = f"o{index}"
        size = item.get("size", {})
        for axis in "xyz":
            size[axis] = min(max(abs(size.get(axis, 0.04)), 0.001), 2.0)
    for index, item in enumerate(scene.get("goals", [])):
        item["id"] = f"g{index}"


# --- hostile payloads -------------------------------------------------------------------------
def hostile_payloads(cls: type[Message]) -> st.SearchStrategy[bytes]:
    """Bytes a forger might send on ``cls``'s key: garbage, wrong JSON, near-misses."""
    valid = valid_objects(cls)
    return st.one_of(
        st.binary(max_size=512),
        JSON_VALUES.map(_dumps),
        st.tuples(valid, st.text(max_size=24), JSON_VALUES).map(_replace_field),
        st.tuples(valid, st.integers(0, 64)).map(_drop_field),
        st.tuples(valid, st.floats(0.0, 1.0)).map(_truncate),
        valid.map(_dumps),  # some hostile payloads are simply valid
    )


def _dumps(value: Any) -> bytes:
    return json.dumps(value).encode()


def _replace_field(args: tuple[dict[str, Any], str, Any]) -> bytes:
    obj, new_key, value = args
    keys = sorted(obj)
    key = keys[len(new_key) % len(keys)] if keys and len(new_key) % 3 else new_key
    return _dumps({**obj, key: value})


def _drop_field(args: tuple[dict[str, Any], int]) -> bytes:
    obj, index = args
    keys = sorted(obj)
    if keys:
        obj = {k: v for k, v in obj.items() if k != keys[index % len(keys)]}
    return _dumps(obj)


def _truncate(args: tuple[dict[str, Any], float]) -> bytes:
    obj, fraction = args
    data = _dumps(obj)
    return data[: int(len(data) * fraction)]


# --- volume: a mutational fuzzer seeded from Hypothesis draws -------------------------------
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
            return _dumps(obj)
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
        return _dumps({**obj, self.rng.choice(keys): self.value()})

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
        return _dumps(copy)

    def _drop_field(self, obj: dict[str, Any]) -> bytes:
        if not obj:
            return b"{}"
        drop = self.rng.choice(list(obj))
        return _dumps({k: v for k, v in obj.items() if k != drop})

    def _extra_field(self, obj: dict[str, Any]) -> bytes:
        return _dumps({**obj, self.value_key() + "_extra": self.value()})

    def _truncate(self, obj: dict[str, Any]) -> bytes:
        data = _dumps(obj)
        return data[: self.rng.randrange(0, max(1, len(data)))]

    def _flip_bytes(self, obj: dict[str, Any]) -> bytes:
        data = bytearray(_dumps(obj))
        for _ in range(self.rng.randrange(1, 8)):
            data[self.rng.randrange(len(data))] = self.rng.randrange(256)
        return bytes(data)

    def _nesting_bomb(self, _obj: dict[str, Any]) -> bytes:
        depth = self.rng.choice([100, 1000, 10_000, 100_000])
        return b"[" * depth + b"]" * depth if self.rng.random() < 0.5 else b'{"a":' * depth

    def _wrong_shape(self, obj: dict[str, Any]) -> bytes:
        return self.rng.choice(
            [_dumps([obj]), _dumps(list(obj.values())), b"null", b'"{}"', b"1e999"]
        )
