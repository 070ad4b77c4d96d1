"""The docs' generated blocks (README.md, docs/contract.md): the key and field tables from the
message declarations, and the flow diagram from the services' manifests. Keys are written as
in any robot cell, ``manigraph/<cell>/world/scene`` (:mod:`manigraph_shared.cells`)."""

from __future__ import annotations

import types
import typing
from enum import Enum

import msgspec

from manigraph_shared.bus import ALIVE_PREFIX
from manigraph_shared.cells import EVERY_CELL, cell_pattern
from manigraph_shared.manifest import load_manifests, mermaid_flow
from manigraph_shared.messages import Delivery, Message

DELIVERY_NOTE = {
    Delivery.RELIABLE: "reliable, congestion BLOCK (never dropped)",
    Delivery.LATEST: "congestion DROP (only the newest matters)",
    Delivery.QUERY: "queryable (request/reply, error replies)",
}


def key_table() -> str:
    """Every key of the contract, written as in any robot cell (``manigraph/<cell>/...``), and
    which of them is per cell and which bus-wide."""
    lines = [
        "| key expression (`<cell>`: the robot cell's name, `cell-1`; the default cell has no "
        "`<cell>/`) | message | delivery | publisher | cells | meaning |",
        "|---|---|---|---|---|---|",
    ]
    for cls in Message.registry.values():
        summary = (cls.__doc__ or "").strip().splitlines()[0].replace("``", "`")
        lines.append(
            f"| `{cell_pattern(cls.key)}` | `{cls.__name__}` | {DELIVERY_NOTE[cls.delivery]} "
            f"| {cls.publisher} | per cell | {summary} |"
        )
    lines.append(
        f"| `{cell_pattern(ALIVE_PREFIX)}/<service>` | liveliness token | - | every service "
        "| per cell | present while the service runs |"
    )
    lines.append(
        f"| `{EVERY_CELL}` | any of the above | as above | - | bus-wide "
        "| every cell's messages: what `manigraph record` and `manigraph view` read in the "
        "default cell, and what a router relays to another site's |"
    )
    return "\n".join(lines)


def field_tables() -> str:
    parts = []
    for cls in Message.registry.values():
        parts.append(f"**`{cls.__name__}`** (`{cell_pattern(cls.key)}`)\n")
        parts.append(_fields(cls))
    return "\n".join(parts)


def _fields(model: type[Message]) -> str:
    lines = ["| field | type | meaning |", "|---|---|---|"]
    hints = typing.get_type_hints(model, include_extras=True)
    for info in msgspec.structs.fields(model):
        kind, metas = _unwrap(hints[info.name])
        lines.append(f"| `{info.name}` | {_type_name(kind)} | {_describe(metas)} |")
    return "\n".join(lines) + "\n"


def _unwrap(annotation: object) -> tuple[object, list[msgspec.Meta]]:
    """The plain type of a field and every ``Meta`` declared on it, outermost last: those on
    the type itself, then those on a union's members (``Annotated[float, Meta(ge=0)] | None``)."""
    metas: list[msgspec.Meta] = []
    if typing.get_origin(annotation) is typing.Annotated:
        annotation, *extras = typing.get_args(annotation)
        metas = [extra for extra in extras if isinstance(extra, msgspec.Meta)]
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        members = []
        for member in typing.get_args(annotation):
            plain, inner = _unwrap(member)
            members.append(plain)
            metas = inner + metas
        annotation = typing.Union[tuple(members)]  # noqa: UP007  (built from parts)
    return annotation, metas


def _type_name(annotation: object) -> str:
    origin = typing.get_origin(annotation)
    if origin is list:
        (inner,) = typing.get_args(annotation)
        inner, _ = _unwrap(inner)
        return f"list[{getattr(inner, '__name__', inner)}]"
    if origin in (typing.Union, types.UnionType):
        return " \\| ".join(_plain(arg) for arg in typing.get_args(annotation))
    return _plain(annotation)


def _plain(annotation: object) -> str:
    if isinstance(annotation, type) and issubclass(annotation, Enum):
        return " \\| ".join(f"`{member.value}`" for member in annotation)
    if annotation is type(None):
        return "null"
    return getattr(annotation, "__name__", str(annotation))


def _describe(metas: list[msgspec.Meta]) -> str:
    text = next((m.description for m in reversed(metas) if m.description), "") or ""
    for meta in metas:
        for bound in ("ge", "le", "max_length"):
            value = getattr(meta, bound, None)
            if value is not None:
                text += f" ({bound} {value})"
    return text.strip()


def flow_diagram() -> str:
    """Who sends what to whom, from every installed package's manifest (Mermaid)."""
    return mermaid_flow(load_manifests().values())


def flow_block() -> str:
    """The flow diagram as a fenced Mermaid block, as the docs show it."""
    return f"```mermaid\n{flow_diagram()}\n```"
