"""The docs' generated blocks (README.md, docs/contract.md): the key and field tables from the
message declarations, and the flow diagram from the services' manifests."""

from __future__ import annotations

import typing
from enum import Enum

from pydantic import BaseModel
from pydantic.fields import FieldInfo

from manigraph_shared.manifest import load_manifests, mermaid_flow
from manigraph_shared.messages import Delivery, Message

DELIVERY_NOTE = {
    Delivery.RELIABLE: "reliable, congestion BLOCK (never dropped)",
    Delivery.LATEST: "congestion DROP (only the newest matters)",
    Delivery.QUERY: "queryable (request/reply, error replies)",
}


def key_table() -> str:
    lines = [
        "| key expression | message | delivery | publisher | meaning |",
        "|---|---|---|---|---|",
    ]
    for cls in Message.registry.values():
        summary = (cls.__doc__ or "").strip().splitlines()[0].replace("``", "`")
        lines.append(
            f"| `{cls.key}` | `{cls.__name__}` | {DELIVERY_NOTE[cls.delivery]} "
            f"| {cls.publisher} | {summary} |"
        )
    lines.append(
        "| `manigraph/alive/<service>` | liveliness token | - | every service | "
        "present while the service runs |"
    )
    lines.append(
        "| `manigraph/<cell>/...` | any of the above | as above | that cell's services | "
        "the same key in robot cell `<cell>`, its second segment (`manigraph/cell-1/world/scene`); "
        "the default cell has none (`docs/scaling.md`) |"
    )
    return "\n".join(lines)


def field_tables() -> str:
    parts = []
    for cls in Message.registry.values():
        parts.append(f"**`{cls.__name__}`** (`{cls.key}`)\n")
        parts.append(_fields(cls))
    return "\n".join(parts)


def _fields(model: type[BaseModel], prefix: str = "") -> str:
    lines = ["| field | type | meaning |", "|---|---|---|"] if not prefix else []
    for name, info in model.model_fields.items():
        lines.append(f"| `{prefix}{name}` | {_type_name(info)} | {_describe(info)} |")
    return "\n".join(lines) + ("\n" if not prefix else "")


def _type_name(info: FieldInfo) -> str:
    annotation = info.annotation
    origin = typing.get_origin(annotation)
    if origin is list:
        (inner,) = typing.get_args(annotation)
        return f"list[{inner.__name__}]"
    if origin in (typing.Union, __import__("types").UnionType):
        return " \\| ".join(_plain(arg) for arg in typing.get_args(annotation))
    return _plain(annotation)


def _plain(annotation: object) -> str:
    if isinstance(annotation, type) and issubclass(annotation, Enum):
        return " \\| ".join(f"`{member.value}`" for member in annotation)
    if annotation is type(None):
        return "null"
    return getattr(annotation, "__name__", str(annotation))


def _describe(info: FieldInfo) -> str:
    text = info.description or ""
    for item in info.metadata:
        for bound in ("ge", "le", "max_length"):
            value = getattr(item, bound, None)
            if value is not None:
                text += f" ({bound} {value})"
    return text.strip()


def flow_diagram() -> str:
    """Who sends what to whom, from every installed package's manifest (Mermaid)."""
    return mermaid_flow(load_manifests().values())


def flow_block() -> str:
    """The flow diagram as a fenced Mermaid block, as the docs show it."""
    return f"```mermaid\n{flow_diagram()}\n```"
