"""Hypothesis strategies for every message type: valid messages and hostile payloads.

Used by the reliability suite (``tests/reliability/``) and the soak (``bench/soak.py``); it
needs the workspace's dev dependency group (``hypothesis``), which no service image installs.

For floods of hundreds of thousands of payloads, :mod:`manigraph_testkit.mutation_fuzzer`
mutates a pool of these draws instead.

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
    schema = cls.json_schema()
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
    elif name == "CameraInfo" and len(obj.get("camera_matrix", [])) == 9:
        k = obj["camera_matrix"]  # a pinhole: fx, fy > 0, zeros where the model has them
        obj["camera_matrix"] = [abs(k[0]) + 1.0, 0.0, k[2], 0.0, abs(k[4]) + 1.0, k[5], 0, 0, 1.0]
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
        JSON_VALUES.map(json_bytes),
        st.tuples(valid, st.text(max_size=24), JSON_VALUES).map(_replace_field),
        st.tuples(valid, st.integers(0, 64)).map(_drop_field),
        st.tuples(valid, st.floats(0.0, 1.0)).map(_truncate),
        valid.map(json_bytes),  # some hostile payloads are simply valid
    )


def json_bytes(value: Any) -> bytes:
    """``value`` as the JSON bytes a publisher would send."""
    return json.dumps(value).encode()


def _replace_field(args: tuple[dict[str, Any], str, Any]) -> bytes:
    obj, new_key, value = args
    keys = sorted(obj)
    key = keys[len(new_key) % len(keys)] if keys and len(new_key) % 3 else new_key
    return json_bytes({**obj, key: value})


def _drop_field(args: tuple[dict[str, Any], int]) -> bytes:
    obj, index = args
    keys = sorted(obj)
    if keys:
        obj = {k: v for k, v in obj.items() if k != keys[index % len(keys)]}
    return json_bytes(obj)


def _truncate(args: tuple[dict[str, Any], float]) -> bytes:
    obj, fraction = args
    data = json_bytes(obj)
    return data[: int(len(data) * fraction)]
