"""What each process consumes and produces, declared once beside it (like a dora node manifest).

A :class:`Manifest` names the messages a service subscribes to, publishes, answers as a
queryable and asks as a client. Ports that only exist for some implementations carry the
*ability* they need: the physics sim offers ``joint_trajectories`` (its backend moves a jointed
arm) and the ``panda-sim`` skills driver needs it. From the manifests alone, ``manigraph up``
matches a skills driver to the sim backend it starts, and the README's flow diagram is drawn
(and checked for drift like the contract tables).

Packages publish their manifests as entry points in the ``manigraph.manifests`` group; a
manifest module imports nothing but the contract, so reading every manifest is cheap.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from importlib.metadata import entry_points

from manigraph_shared.cells import EVERY_CELL, cell_pattern
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Message

GROUP = "manigraph.manifests"


@dataclass(frozen=True)
class Port:
    """One message type on one side of a service; ``ability`` gates it (None: always)."""

    message: type[Message]
    ability: str | None = None

    @property
    def key(self) -> str:
        """The port's key in any cell: ``manigraph/<cell>/world/scene`` (a process joins one
        cell with ``--cell``; in the default cell the key has no ``<cell>/``)."""
        return cell_pattern(self.message.key)


def port(message: type[Message], ability: str | None = None) -> Port:
    return Port(message, ability)


@dataclass(frozen=True)
class Manifest:
    """A process's declared inputs and outputs.

    ``variants`` maps each registered implementation chosen by ``variant_option`` (a sim
    backend, a robot driver) to the abilities it brings: for a world, what it offers; for a
    robot driver, what it needs from the world. A gated port exists only with its ability.
    """

    service: str
    summary: str
    consumes: tuple[Port, ...] = ()
    produces: tuple[Port, ...] = ()
    serves: tuple[Port, ...] = ()
    requests: tuple[Port, ...] = ()
    variant_option: str | None = None
    variants: Mapping[str, frozenset[str]] = field(default_factory=dict)
    #: Reads every message of every cell, ``manigraph/**`` (the recorder, the live viewer; with
    #: ``--cell NAME``, that cell's only).
    observes_all: bool = False

    def __post_init__(self) -> None:
        declared = set().union(*self.variants.values()) if self.variants else set()
        for p in (*self.consumes, *self.produces, *self.serves, *self.requests):
            if p.ability is not None and p.ability not in declared:
                raise ConfigError(
                    f"{self.service}.manifest", f"port {p.key} needs undeclared '{p.ability}'"
                )

    def abilities(self, variant: str) -> frozenset[str]:
        if variant not in self.variants:
            raise ConfigError(
                self.variant_option or self.service,
                f"'{variant}' is not one of {', '.join(sorted(self.variants))}",
            )
        return self.variants[variant]


def load_manifests() -> dict[str, Manifest]:
    """Every installed package's manifests, by service name."""
    found: dict[str, Manifest] = {}
    for entry in entry_points(group=GROUP):
        manifest = entry.load()
        if not isinstance(manifest, Manifest):
            raise ConfigError(f"manifest {entry.name}", f"{entry.value} is not a Manifest")
        found[manifest.service] = manifest
    return found


#: What each sim backend offers a robot driver. Part of the contract, so a process whose
#: image lacks the sim (the skills container) still matches its driver to the world; the
#: sim's manifest declares its variants from this table.
WORLD_ABILITIES: Mapping[str, frozenset[str]] = {
    "geometric": frozenset({"gripper_commands"}),
    "physics": frozenset({"joint_trajectories", "camera"}),
}


def driver_for_backend(backend: str, manifests: Mapping[str, Manifest] | None = None) -> str:
    """The skills driver for the sim backend ``backend``: from the installed sim manifest, or
    (where the sim is not installed) from :data:`WORLD_ABILITIES`."""
    manifests = load_manifests() if manifests is None else manifests
    world = manifests.get("sim") or Manifest(
        "sim", "world", variant_option="backend", variants=dict(WORLD_ABILITIES)
    )
    if "skills" not in manifests:
        raise ConfigError("driver", "the skills manifest is not installed")
    return driver_for_world(world, backend, manifests["skills"])


def driver_for_world(world: Manifest, backend: str, robot: Manifest) -> str:
    """The robot driver whose needs the world's ``backend`` offers (the first in name order
    that does). A driver that needs an ability no world offers (a real robot) is never picked."""
    offered = world.abilities(backend)
    matching = sorted(name for name, needs in robot.variants.items() if needs and needs <= offered)
    if not matching:
        raise ConfigError(
            robot.variant_option or robot.service,
            f"no {robot.service} driver needs only what {world.service} '{backend}' offers "
            f"({', '.join(sorted(offered)) or 'nothing'})",
        )
    return matching[0]


def mermaid_flow(manifests: Iterable[Manifest]) -> str:
    """A Mermaid flowchart: one arrow from each producer to each consumer, labelled with the
    keys between them (dotted where an ability gates them); queries from client to server;
    the recorder and the viewer under everything. Keys show their cell segment
    (``manigraph/<cell>/...``, written so Mermaid prints the brackets)."""
    items = sorted(manifests, key=lambda m: m.service)
    ids = {m.service: m.service.upper().replace("-", "_") for m in items}
    lines = ["flowchart LR"]
    for m in items:
        lines.append(f'  {ids[m.service]}["{m.service}<br/>{m.summary}"]')
    edges: dict[tuple[str, str, bool], set[str]] = {}
    for producer in items:
        for out in producer.produces:
            for consumer in items:
                for inp in consumer.consumes:
                    if inp.message is out.message and consumer is not producer:
                        gate = out.ability or inp.ability
                        label = out.key if gate is None else f"{out.key} ({gate})"
                        edge = (ids[producer.service], ids[consumer.service], gate is not None)
                        edges.setdefault(edge, set()).add(label)
        for asked in producer.requests:
            for server in items:
                if any(s.message is asked.message for s in server.serves):
                    edge = (ids[producer.service], ids[server.service], True)
                    edges.setdefault(edge, set()).add(f"query {asked.key}")
    for (source, target, dotted), labels in sorted(edges.items()):
        text = "<br/>".join(_mermaid_text(label) for label in sorted(labels))
        arrow = f'-. "{text}" .->' if dotted else f'-- "{text}" -->'
        lines.append(f"  {source} {arrow} {target}")
    watchers = [m for m in items if m.observes_all]
    sources = [m for m in items if m.produces and not m.observes_all]
    for watcher in watchers:
        names = " & ".join(ids[m.service] for m in sources)
        lines.append(f'  {names} -- "{EVERY_CELL} (every cell)" --> {ids[watcher.service]}')
    return "\n".join(lines)


def _mermaid_text(text: str) -> str:
    """``text`` for a Mermaid label: ``<`` and ``>`` as Mermaid's entity codes (a bare
    ``<cell>`` would be taken for an HTML tag and vanish)."""
    return text.replace("<", "#lt;").replace(">", "#gt;")
