"""What ``manigraph up`` prints once its stack is up: the line a client needs to reach it, and
what to run next."""

from __future__ import annotations

from pathlib import Path

#: The TLS identity a person's client commands present (``manigraph certs`` makes it).
CLIENT_IDENTITY = "client"


def connect_flags(endpoint: str, tls_dir: Path | None) -> str:
    """The flags a client command needs to reach the stack at ``endpoint``."""
    flags = f"-e {endpoint}"
    if tls_dir is not None:
        flags += f" --tls-dir {tls_dir} --tls-identity {CLIENT_IDENTITY}"
    return flags


#: What to run next, and what it does; ``{}`` takes the connect flags. With TLS, the view
#: presents its own certificate (a service: access control grants it its liveliness).
NEXT = (
    ("manigraph status{}", "the stack at a glance (doctor: alive or not)"),
    ("manigraph run{} --episodes 3", "episodes on this stack"),
    ("manigraph stop{}", "emergency stop; `manigraph resume` releases it"),
    ("manigraph view{}", "the live stack in Foxglove (ws://127.0.0.1:8765)"),
    ("manigraph explain{}", "why the planner chose its latest action"),
)
OWN_IDENTITY = {"manigraph view{}": "view"}


def client_environment(endpoint: str, tls_dir: Path | None) -> str:
    """The same as :func:`connect_flags`, as the variables every client reads."""
    names = {"MANIGRAPH_ZENOH_CONNECT": endpoint}
    if tls_dir is not None:
        names |= {"MANIGRAPH_TLS_DIR": str(tls_dir), "MANIGRAPH_TLS_IDENTITY": CLIENT_IDENTITY}
    return " ".join(f"{name}={value}" for name, value in names.items())


def guide(
    endpoint: str,
    tls_dir: Path | None,
    cells: list[str] | None = None,
    next_steps: bool = True,
) -> list[str]:
    """The lines ``up`` prints after ``stack is up``: the connect line first, always; with
    ``next_steps`` the commands to try. With TLS, where the certificates are; with ``cells``,
    that a client picks one with ``--cell``."""
    flags = connect_flags(endpoint, tls_dir)
    lines = [f"clients: manigraph doctor {flags}"]
    if tls_dir is not None:
        lines.append(
            f"certificates: {tls_dir} (made for this run, removed when it stops; docs/security.md)"
        )
    if cells:
        identity = f" --tls-identity {CLIENT_IDENTITY}.NAME" if tls_dir is not None else ""
        lines.append(f"cells: {', '.join(cells)} (a client picks one: --cell NAME{identity})")
    if next_steps:
        # the TLS flags are long: said once, as variables, instead of on every command
        short = tls_dir is None
        if not short:
            lines.append(f"next, after: export {client_environment(endpoint, tls_dir)}")
        else:
            lines.append("next:")
        commands = [
            (command.format(f" {flags}" if short else _own_identity(command, tls_dir)), what)
            for command, what in NEXT
        ]
        width = max(len(command) for command, _ in commands)
        lines += [f"  {command:<{width}}  {what}" for command, what in commands]
    return lines


def _own_identity(command: str, tls_dir: Path | None) -> str:
    identity = OWN_IDENTITY.get(command)
    return f" --tls-identity {identity}" if identity and tls_dir is not None else ""
