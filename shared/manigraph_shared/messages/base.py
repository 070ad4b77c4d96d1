"""The one place a message type becomes wire format, validation, MCAP schema and docs.

A message type is a msgspec struct that subclasses :class:`Message` and declares, beside its
fields, the key expression it travels on and how it may be delivered. From that single
declaration come:

* ``encode`` / ``decode`` — JSON on the wire, validated on the way in;
* ``mcap_schema`` — the JSON Schema written into every MCAP channel carrying the type;
* the key and field tables of README.md and docs/contract.md (``manigraph keys --fields``).

Decoding never raises anything but :class:`~manigraph_shared.errors.MessageError`, whose
``problems`` name every offending field.
"""

from __future__ import annotations

import functools
import math
import re
import sys
import threading
import types
import typing
from enum import Enum, StrEnum
from typing import Annotated, Any, ClassVar, Self

import msgspec
from msgspec import Meta

from manigraph_shared.errors import MessageError

#: No manigraph message is legitimately larger than this; bigger payloads are rejected unread.
MAX_PAYLOAD_BYTES = 1 << 20

PREFIX = "manigraph"

#: The contract's version, written into every MCAP log (``mcap_log.contract_version`` reads it).
#: Versions 2 and 3 added fields with defaults, so a log of an older version decodes as is;
#: version 4 renamed some, and a payload of 1-3 is upgraded as it is decoded (the golden logs
#: of tests/golden are version 1):
#:
#: * 2: objects' ``attributes`` and goals' ``accepts`` (Scene, TaskLayout); the end event's
#:   ``goals_wrong_object``; ServiceStatus's version, start, policy, checkpoint and e-stop;
#:   EmergencyStop's ``by``; the ``explainer_warming_up`` refusal; DepthImage.
#: * 3: goals' ``attributes`` (Scene, TaskLayout); EpisodeRequest's ``rules``; the end event's
#:   ``rule_violations``.
#: * 4: the contract knows no task family. A scene's ``racks`` became its ``fixtures`` (of a
#:   kind the family defines, with a ``state`` it reads) and a goal's ``rack`` its
#:   ``fixture``; an action's ``tray_action`` became its ``family_action`` (a name the
#:   family defines, on the fixture named as object and goal) and the robot's
#:   ``toggle_tray`` op ``operate``; an episode request names its ``family`` and carries
#:   the family's ``options`` (the ``preference`` moved there). This renamed fields, so a
#:   payload of versions 1-3 is read through its type's ``upgrade`` (``messages.legacy``)
#:   when it does not decode as is.
CONTRACT_VERSION = 4

Identifier = Annotated[
    str,
    Meta(pattern=r"^[A-Za-z0-9_.:\-]{1,64}$", description="identifier, 1-64 of [A-Za-z0-9_.:-]"),
]
Stamp = Annotated[float, Meta(ge=0.0, description="seconds since the Unix epoch")]
Metres = Annotated[float, Meta(ge=-100.0, le=100.0, description="metres")]
Unit = Annotated[float, Meta(ge=-1.0, le=1.0)]
#: Attributes one object may carry (colour, label, ...), keys one goal's ``accepts`` may list,
#: and the names a fixture's state or a request's family options may hold.
MAX_ATTRIBUTES = 16
AttributeName = Annotated[
    str,
    Meta(
        pattern=r"^[a-z][a-z0-9_]{0,31}$",
        description="attribute name: lower case, 1-32 of [a-z0-9_], starting with a letter",
    ),
]
#: A name a family defines (a fixture's kind, a family action): lower case, like an attribute.
FamilyName = Annotated[
    str,
    Meta(
        pattern=r"^[a-z][a-z0-9_]{0,31}$",
        description="a name the task's family defines: lower case, 1-32 of [a-z0-9_]",
    ),
]
#: A scalar a family reads: a fixture's state, an episode request's option.
FamilyScalar = (
    bool
    | Annotated[float, Meta(ge=-1e6, le=1e6)]
    | Annotated[str, Meta(min_length=1, max_length=64)]
)


class Delivery(StrEnum):
    """How a key is delivered; decides Zenoh reliability and congestion control."""

    #: Every sample matters (decisions, results, events): reliable, congestion control BLOCK.
    RELIABLE = "reliable"
    #: Only the newest sample matters (state streams): congestion control DROP.
    LATEST = "latest"
    #: Request/reply over a Zenoh queryable; errors come back as error replies.
    QUERY = "query"


class _StructMeta(msgspec.StructMeta):
    """msgspec calls a struct's ``__post_init__`` for every value it builds, from C into
    Python; a K = 40 Scene builds ~280 values, so on the wire this is the hot path. A struct
    gets one only when it has work to do (a ``_check`` or an enum field, its own or
    inherited), and then the least: its ``_check`` itself, or a loop over its enum fields."""

    def __new__(
        mcls, name: str, bases: tuple[type, ...], namespace: dict[str, Any], **kw: Any
    ) -> _StructMeta:
        ours = any(isinstance(base, _StructMeta) for base in bases)  # not the root itself
        if ours and "__post_init__" not in namespace:
            own = _own_enum_fields(namespace)
            inherited = tuple(f for base in bases for f in getattr(base, "_enum_names", ()))
            checks = "_check" in namespace or any(getattr(base, "_checks", False) for base in bases)
            namespace["_checks"] = checks
            unresolved = any(getattr(b, "__post_init__", None) is _post_init_any for b in bases)
            if own is None or unresolved:  # a forward reference: read the fields per value
                namespace["__post_init__"] = _post_init_any
            else:
                enums = inherited + own
                namespace["_enum_names"] = enums
                if own or (enums and "_check" in namespace):
                    namespace["__post_init__"] = _post_init_for(enums, checks)
                elif "_check" in namespace and not enums:
                    namespace["__post_init__"] = namespace["_check"]
                # otherwise the base's own (or none) still holds
        return super().__new__(mcls, name, bases, namespace, **kw)


def _own_enum_fields(namespace: dict[str, Any]) -> tuple[tuple[str, type[Enum]], ...] | None:
    """The fields a class body declares as (optionally) an enum; None if one cannot be
    resolved yet (a forward reference)."""
    module = sys.modules.get(namespace.get("__module__", ""))
    scope = vars(module) if module is not None else {}
    found = []
    for name, annotation in namespace.get("__annotations__", {}).items():
        if isinstance(annotation, str) and annotation.startswith("ClassVar["):
            continue  # not a field
        try:  # a string under ``from __future__ import annotations``: what it names
            kind = (
                eval(annotation, scope, dict(namespace))
                if isinstance(annotation, str)
                else annotation
            )
        except Exception:
            return None
        enum = _enum_in(kind)
        if enum is not None:
            found.append((name, enum))
    return tuple(found)


def _post_init_for(enums: tuple[tuple[str, type[Enum]], ...], checks: bool) -> Any:
    """A ``__post_init__`` turning plain values of ``enums`` into the enum, then checking."""
    setattr_ = msgspec.structs.force_setattr

    def __post_init__(self: Struct) -> None:
        for name, kind in enums:
            value = getattr(self, name)
            if value is not None and value.__class__ is not kind:
                setattr_(self, name, kind(value))
        if checks:
            self._check()

    return __post_init__


def _post_init_any(self: Struct) -> None:
    for name, kind in _enum_fields(type(self)):
        value = getattr(self, name)
        if value is not None and value.__class__ is not kind:
            msgspec.structs.force_setattr(self, name, kind(value))
    self._check()


class Struct(
    msgspec.Struct, metaclass=_StructMeta, frozen=True, kw_only=True, forbid_unknown_fields=True
):
    """A nested value inside a message: strict, immutable, finite. Subclasses repeat
    ``frozen=True, kw_only=True`` (msgspec applies ``kw_only`` to a class's own fields).

    A msgspec struct: decoding validates types, bounds, patterns and lengths in C, and
    ``_check`` (a subclass's cross-field rules, raising ``ValueError("field: why")``) runs on
    every decoded or constructed value. Enum fields given as their plain values are turned
    into the enum on construction, as decoding does.
    """

    def _check(self) -> None:
        """Cross-field rules; raise ``ValueError("field: why")``."""

    def replace(self, **changes: Any) -> Self:
        """A copy with ``changes``' fields replaced (checked as on construction)."""
        return msgspec.structs.replace(self, **changes)

    def to_builtins(self, exclude: set[str] | frozenset[str] = frozenset()) -> dict[str, Any]:
        """The value as JSON-able builtins (enums as their values, bytes as base64), less the
        top-level fields in ``exclude``."""
        data: dict[str, Any] = msgspec.to_builtins(self, enc_hook=_builtin)
        for name in exclude:
            data.pop(name, None)
        return data

    def to_json(self) -> str:
        """The value as JSON text, as the wire carries it."""
        return _ENCODER.encode(self).decode()

    @classmethod
    def from_builtins(cls, data: object) -> Self:
        """``data`` (JSON-like builtins) as this type, or :class:`MessageError`."""
        try:
            return msgspec.convert(data, cls, strict=False)
        except msgspec.ValidationError as exc:
            raise MessageError(_type_name(cls), "", [_problem(str(exc))]) from None

    @classmethod
    def max_length(cls, field: str) -> int:
        """The declared ``max_length`` of ``field`` (for checks before a message is built)."""
        info = next(f for f in msgspec.inspect.type_info(cls).fields if f.name == field)  # type: ignore[attr-defined]
        kind = info.type
        while True:
            if getattr(kind, "max_length", None) is not None:
                return int(kind.max_length)
            inner = getattr(kind, "type", None) or next(
                (t for t in getattr(kind, "types", ()) if getattr(t, "max_length", None)), None
            )
            if inner is None:
                raise KeyError(f"{cls.__name__}.{field} declares no max_length")
            kind = inner

    @classmethod
    def json_schema(cls) -> dict[str, Any]:
        """JSON Schema of this type, nested types under ``$defs``."""
        schema = msgspec.json.schema(cls)
        defs: dict[str, Any] = schema.get("$defs", {})
        top = defs.pop(cls.__name__)
        return {**top, "$defs": defs} if defs else top


@functools.cache
def _enum_fields(cls: type) -> tuple[tuple[str, type[Enum]], ...]:
    """The fields of ``cls`` typed as an enum (or an optional one), read once per type."""
    found = []
    for info in msgspec.structs.fields(cls):
        kind = _enum_in(info.type)
        if kind is not None:
            found.append((info.name, kind))
    return tuple(found)


def _enum_in(annotation: object) -> type[Enum] | None:
    """The enum an annotation is (or is optionally): ``Kind`` or ``Kind | None``."""
    if isinstance(annotation, type) and issubclass(annotation, Enum):
        return annotation
    if typing.get_origin(annotation) is Annotated:
        return _enum_in(typing.get_args(annotation)[0])
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    union = typing.get_origin(annotation) in (typing.Union, types.UnionType)
    return _enum_in(args[0]) if union and len(args) == 1 else None


def _builtin(value: object) -> object:
    """numpy scalars and arrays (sims compute with numpy) as the builtins they hold."""
    tolist = getattr(value, "tolist", None)
    if tolist is not None:
        return tolist()
    raise NotImplementedError(f"cannot encode a {type(value).__name__}")


_ENCODER = msgspec.json.Encoder(enc_hook=_builtin)
_PREPARING = threading.Lock()


class Vector3(Struct, frozen=True, kw_only=True):
    """A position in metres."""

    x: Metres
    y: Metres
    z: Metres

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.z)


class Quaternion(Struct, frozen=True, kw_only=True):
    """A unit quaternion (x, y, z, w); identity by default."""

    x: Unit = 0.0
    y: Unit = 0.0
    z: Unit = 0.0
    w: Unit = 1.0

    def _check(self) -> None:
        squared = self.x * self.x + self.y * self.y + self.z * self.z + self.w * self.w
        if not _UNIT_LOW <= squared <= _UNIT_HIGH:  # |norm - 1| <= 1e-3, without a root
            raise ValueError(f"not a unit quaternion (norm {math.sqrt(squared):.4f})")


_UNIT_LOW, _UNIT_HIGH = (1.0 - 1e-3) ** 2, (1.0 + 1e-3) ** 2


class Message(Struct, frozen=True, kw_only=True):
    """Base of every type that travels on the bus.

    Subclasses set ``key`` (may hold ``{field}`` placeholders filled from the instance, e.g.
    ``manigraph/status/{service}``), ``delivery`` and ``publisher`` (who sends it).
    """

    key: ClassVar[str]
    delivery: ClassVar[Delivery]
    publisher: ClassVar[str]
    registry: ClassVar[dict[str, type[Message]]] = {}
    _decoder: ClassVar[msgspec.json.Decoder[Any] | None] = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls._decoder = None
        if "key" in cls.__dict__:
            Message.registry[cls.type_name()] = cls

    # --- identity ---------------------------------------------------------------------------
    @classmethod
    def type_name(cls) -> str:
        return _type_name(cls)

    @classmethod
    def key_pattern(cls) -> str:
        """The key expression with every placeholder widened to ``*``."""
        return re.sub(r"\{[a-z_]+\}", "*", cls.key)

    def key_for(self) -> str:
        """The concrete key this instance is published on."""
        names = _placeholders(self.key)
        if not names:
            return self.key
        return self.key.format(**{name: getattr(self, name) for name in names})

    # --- wire format ------------------------------------------------------------------------
    def encode(self) -> bytes:
        return _ENCODER.encode(self)

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
        decoder = cls._decoder or cls.prepare()
        try:
            return decoder.decode(payload)
        except (msgspec.DecodeError, ValueError) as exc:  # ValueError: bytes that are not UTF-8
            older = cls._older(payload)
            if older is None:
                raise MessageError(cls.type_name(), key, _problems(cls, payload, exc)) from None
        try:  # a payload of an older contract version, in this version's fields
            return decoder.decode(older)
        except (msgspec.DecodeError, ValueError) as exc:
            raise MessageError(cls.type_name(), key, _problems(cls, older, exc)) from None

    @classmethod
    def upgrade(cls, data: dict[str, Any]) -> dict[str, Any]:
        """``data``, a payload of an older contract version as builtins, in this version's
        fields (a type whose fields changed overrides this; ``messages.legacy``)."""
        return data

    @classmethod
    def _older(cls, payload: bytes | bytearray | memoryview) -> bytes | None:
        """``payload`` upgraded from an older version of this type (a log of an older
        contract replayed), or None if it holds nothing older. Only a refused payload comes
        here, so payloads of this version pay nothing for it."""
        if cls.upgrade.__func__ is Message.upgrade.__func__:  # type: ignore[attr-defined]
            return None
        try:
            data = msgspec.json.decode(payload)
        except (msgspec.DecodeError, ValueError, RecursionError):
            return None
        if not isinstance(data, dict):
            return None
        upgraded = cls.upgrade(data)
        return None if upgraded is data else _ENCODER.encode(upgraded)

    @classmethod
    def prepare(cls) -> msgspec.json.Decoder[Any]:
        """Build this type's decoder (and msgspec's type information for every struct in
        it). msgspec builds that information lazily and not thread-safely: two Zenoh threads
        decoding a type's first samples at once crashed a process (SIGSEGV). Every
        registered type is prepared when ``manigraph_shared.messages`` is imported, before
        any thread exists; the lock covers a type defined later."""
        with _PREPARING:
            if cls._decoder is None:
                cls._decoder = msgspec.json.Decoder(cls)
            return cls._decoder

    @classmethod
    def mcap_schema(cls) -> bytes:
        schema = cls.json_schema()
        schema["title"] = cls.type_name()
        return msgspec.json.encode(schema)


def _type_name(cls: type) -> str:
    return f"{PREFIX}.{cls.__name__}"


@functools.cache
def _placeholders(key: str) -> tuple[str, ...]:
    return tuple(re.findall(r"\{([a-z_]+)\}", key))


_AT = re.compile(r"^(?P<message>.*?)(?: - at `\$(?P<path>[^`]*)`)?$", re.DOTALL)
_NAMED = re.compile(r"^(?P<field>[a-z_.]+): (?P<message>.*)$", re.DOTALL)
_KEY_IN_MESSAGE = re.compile(r"(?:missing required|unknown) field `(?P<field>[^`]+)`")


def _problem(text: str) -> tuple[str, str]:
    """msgspec's ``why - at `$.a[0].b``` as ``("a.0.b", why)``; a check's ``"field: why"``
    gets its field appended to the path, a missing or unknown field its name."""
    match = _AT.match(text)
    message = match.group("message") if match else text
    path = (match.group("path") or "") if match else ""
    parts = [p for p in re.split(r"[.\[\]]+", path) if p]
    named = _NAMED.match(message)
    if named:
        parts.append(named.group("field"))
        message = named.group("message")
    else:
        keyed = _KEY_IN_MESSAGE.search(message)
        if keyed:
            parts.append(keyed.group("field"))
    return (".".join(parts) or "<payload>", message)


def _non_finite(payload: bytes | bytearray | memoryview) -> list[tuple[str, str]]:
    """Where JSON that is valid but for NaN or Infinity has them (JavaScript writes them)."""
    import json

    try:
        data = json.loads(bytes(payload))
    except (ValueError, RecursionError):
        return []
    found: list[tuple[str, str]] = []

    def walk(value: object, path: str) -> None:
        if isinstance(value, float) and not math.isfinite(value):
            found.append((path.lstrip(".") or "<payload>", f"{value} is not a finite number"))
        elif isinstance(value, dict):
            for name, item in value.items():
                walk(item, f"{path}.{name}")
        elif isinstance(value, list):
            for index, item in enumerate(value):
                walk(item, f"{path}.{index}")

    try:
        walk(data, "")
    except RecursionError:
        return []
    return found


def _problems(
    cls: type[Struct], payload: bytes | bytearray | memoryview, exc: Exception
) -> list[tuple[str, str]]:
    """Every problem of a refused payload, by field (the fast decoder stops at the first).

    Only refused payloads come here: the payload is parsed without a type, then each field is
    checked on its own, so a payload of the wrong type names all it lacks and all it has
    extra, as a person fixing it needs."""
    if not isinstance(exc, msgspec.ValidationError):  # not JSON (a ValidationError is a
        return _non_finite(payload) or [("<payload>", str(exc))]  # DecodeError too)
    first = [_problem(str(exc))]
    try:
        data = msgspec.json.decode(payload)
    except (msgspec.DecodeError, ValueError, RecursionError):  # ValueError: not UTF-8
        return first
    if not isinstance(data, dict):
        return first
    problems: list[tuple[str, str]] = []
    declared = {info.encode_name: info for info in msgspec.structs.fields(cls)}
    for name in data:
        if name not in declared:
            problems.append((name, "not a field of this message"))
    for name, info in declared.items():
        if name not in data:
            if info.required:
                problems.append((name, "missing"))
            continue
        try:
            msgspec.convert(data[name], info.type, strict=False)
        except msgspec.ValidationError as field_exc:
            field, message = _problem(str(field_exc))
            problems.append((name if field == "<payload>" else f"{name}.{field}", message))
        except RecursionError:
            problems.append((name, "nested too deeply"))
    return problems or first


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
