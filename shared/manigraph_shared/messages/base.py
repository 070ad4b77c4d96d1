"""The one place a message type becomes wire format, validation, MCAP schema and docs.

A message type is a pydantic model that subclasses :class:`Message` and declares, beside its
fields, the key expression it travels on and how it may be delivered. From that single
declaration come:

* ``encode`` / ``decode`` — JSON on the wire, validated on the way in;
* ``mcap_schema`` — the JSON Schema written into every MCAP channel carrying the type;
* the key and field tables of README.md and docs/contract.md (``manigraph keys --fields``).

Decoding never raises anything but :class:`~manigraph_shared.errors.MessageError`, whose
``problems`` name every offending field.
"""

from __future__ import annotations

import json
import math
import re
from enum import StrEnum
from typing import Annotated, Any, ClassVar, Self

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from manigraph_shared.errors import MessageError

#: No manigraph message is legitimately larger than this; bigger payloads are rejected unread.
MAX_PAYLOAD_BYTES = 1 << 20

PREFIX = "manigraph"

Identifier = Annotated[
    str,
    Field(pattern=r"^[A-Za-z0-9_.:\-]{1,64}$", description="identifier, 1-64 of [A-Za-z0-9_.:-]"),
]
Stamp = Annotated[float, Field(ge=0.0, description="seconds since the Unix epoch")]
Metres = Annotated[float, Field(ge=-100.0, le=100.0, description="metres")]


class Delivery(StrEnum):
    """How a key is delivered; decides Zenoh reliability and congestion control."""

    #: Every sample matters (decisions, results, events): reliable, congestion control BLOCK.
    RELIABLE = "reliable"
    #: Only the newest sample matters (state streams): congestion control DROP.
    LATEST = "latest"
    #: Request/reply over a Zenoh queryable; errors come back as error replies.
    QUERY = "query"


class Struct(BaseModel):
    """A nested value inside a message: strict, immutable, finite."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


class Vector3(Struct):
    """A position in metres."""

    x: Metres
    y: Metres
    z: Metres

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.z)


class Quaternion(Struct):
    """A unit quaternion (x, y, z, w); identity by default."""

    x: float = Field(0.0, ge=-1.0, le=1.0)
    y: float = Field(0.0, ge=-1.0, le=1.0)
    z: float = Field(0.0, ge=-1.0, le=1.0)
    w: float = Field(1.0, ge=-1.0, le=1.0)

    @model_validator(mode="after")
    def _unit_norm(self) -> Self:
        norm = math.sqrt(self.x**2 + self.y**2 + self.z**2 + self.w**2)
        if abs(norm - 1.0) > 1e-3:
            raise ValueError(f"not a unit quaternion (norm {norm:.4f})")
        return self


class Message(Struct):
    """Base of every type that travels on the bus.

    Subclasses set ``key`` (may hold ``{field}`` placeholders filled from the instance, e.g.
    ``manigraph/status/{service}``), ``delivery`` and ``publisher`` (who sends it).
    """

    key: ClassVar[str]
    delivery: ClassVar[Delivery]
    publisher: ClassVar[str]
    registry: ClassVar[dict[str, type[Message]]] = {}

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        if "key" in cls.__dict__:
            Message.registry[cls.type_name()] = cls

    # --- identity ---------------------------------------------------------------------------
    @classmethod
    def type_name(cls) -> str:
        return f"{PREFIX}.{cls.__name__}"

    @classmethod
    def key_pattern(cls) -> str:
        """The key expression with every placeholder widened to ``*``."""
        return re.sub(r"\{[a-z_]+\}", "*", cls.key)

    def key_for(self) -> str:
        """The concrete key this instance is published on."""
        return self.key.format(**{name: getattr(self, name) for name in _placeholders(self.key)})

    # --- wire format ------------------------------------------------------------------------
    def encode(self) -> bytes:
        return self.model_dump_json().encode()

    @classmethod
    def decode(cls, payload: bytes | bytearray | memoryview, key: str = "") -> Self:
        """Validate ``payload`` into this type or raise :class:`MessageError`."""
        size = len(payload)
        if size > MAX_PAYLOAD_BYTES:
            raise MessageError(
                cls.type_name(),
                key,
                [("<payload>", f"{size} bytes exceeds the {MAX_PAYLOAD_BYTES}-byte limit")],
            )
        try:
            return cls.model_validate_json(bytes(payload))
        except ValidationError as exc:
            raise MessageError(cls.type_name(), key, _problems(exc)) from None

    @classmethod
    def mcap_schema(cls) -> bytes:
        schema = cls.model_json_schema()
        schema["title"] = cls.type_name()
        return json.dumps(schema, separators=(",", ":")).encode()


def _placeholders(key: str) -> list[str]:
    return re.findall(r"\{([a-z_]+)\}", key)


def _problems(exc: ValidationError) -> list[tuple[str, str]]:
    problems = []
    for error in exc.errors(include_url=False):
        field = ".".join(str(part) for part in error["loc"])
        message = error["msg"]
        # Model-level checks say "field: why"; give them the field they are about.
        named = re.match(r"Value error, ([a-z_.]+): (.*)", message)
        if named:
            field = ".".join(part for part in (field, named.group(1)) if part)
            message = named.group(2)
        problems.append((field or "<payload>", message))
    return problems


def key_matches(pattern: str, key: str) -> bool:
    """Whether ``key`` falls under ``pattern`` (``*`` = one chunk, ``**`` = any chunks)."""
    return _match(pattern.split("/"), key.split("/"))


def _match(pattern: list[str], key: list[str]) -> bool:
    if not pattern:
        return not key
    head, rest = pattern[0], pattern[1:]
    if head == "**":
        return any(_match(rest, key[i:]) for i in range(len(key) + 1))
    if not key:
        return False
    return (head == "*" or head == key[0]) and _match(rest, key[1:])


def message_type_for_key(key: str) -> type[Message] | None:
    """The declared type published on ``key``, or None for keys outside the contract."""
    for cls in Message.registry.values():
        if cls.delivery is not Delivery.QUERY and key_matches(cls.key_pattern(), key):
            return cls
    return None
