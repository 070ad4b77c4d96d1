"""Zenoh session settings from the standard flags and their environment variables.

The flags are zenoh-python's usual ones (``--mode --connect --listen --config
--no-multicast-scouting``); each has an environment variable so containers can be configured
without a command line. Flags win over the environment.

``--port N`` is the shorthand ``manigraph up --port N`` uses: the endpoint
``tcp/127.0.0.1:N`` (``tls/127.0.0.1:N`` with ``--tls-dir``), to connect to or, for the router,
to listen on.

Mutual TLS is chosen with ``--tls-dir`` (a directory written by ``manigraph certs``) and
``--tls-identity`` (whose certificate this process presents); endpoints are then
``tls/HOST:PORT``. Without them the bus is plain TCP, meant for loopback development.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path

from manigraph_shared.cells import check_cell
from manigraph_shared.errors import ConfigError

DEFAULT_PORT = 7447
DEFAULT_ROUTER = f"tcp/127.0.0.1:{DEFAULT_PORT}"
DEFAULT_TLS_ROUTER = f"tls/127.0.0.1:{DEFAULT_PORT}"
MODES = ("client", "peer", "router")
#: How long a one-shot client (``doctor``, ``run``, ``stop`` ...) lets nobody listen at its
#: endpoint before it says there is no stack; ``--wait-seconds`` waits longer instead.
NO_STACK_SECONDS = 0.5

ENV = {
    "mode": "MANIGRAPH_ZENOH_MODE",
    "connect": "MANIGRAPH_ZENOH_CONNECT",
    "listen": "MANIGRAPH_ZENOH_LISTEN",
    "config": "MANIGRAPH_ZENOH_CONFIG",
    "no_multicast_scouting": "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING",
    "wait_seconds": "MANIGRAPH_ZENOH_WAIT_SECONDS",
    "tls_dir": "MANIGRAPH_TLS_DIR",
    "tls_identity": "MANIGRAPH_TLS_IDENTITY",
    "cell": "MANIGRAPH_CELL",
}

#: The CA certificate's file name inside a TLS directory written by ``manigraph certs``.
TLS_CA_FILE = "ca.pem"


def tls_files(directory: Path, identity: str) -> tuple[Path, Path, Path]:
    """The CA certificate, the identity's certificate and its private key in ``directory``."""
    return directory / TLS_CA_FILE, directory / f"{identity}.pem", directory / f"{identity}.key"


@dataclass(frozen=True)
class BusConfig:
    """How a process joins the manigraph bus.

    The default is a client of the router on ``tcp/127.0.0.1:7447`` with multicast scouting
    off, which is what ``manigraph up`` and ``compose.yaml`` start.
    """

    mode: str = "client"
    connect: tuple[str, ...] = (DEFAULT_ROUTER,)
    listen: tuple[str, ...] = ()
    config_file: Path | None = None
    multicast_scouting: bool = False
    #: How long a client waits for its router; ``None`` waits forever (services do).
    wait_seconds: float | None = None
    #: A client that finds nobody listening at any of its endpoints for this long gives up at
    #: once, saying there is no stack; ``None``: it waits its ``wait_seconds`` for one.
    no_stack_after: float | None = None
    #: Directory of ``manigraph certs`` output; set, every link is mutual TLS.
    tls_dir: Path | None = None
    #: Whose certificate this process presents (its common name is what access control sees).
    tls_identity: str | None = None
    #: The robot cell whose keys this process uses (:mod:`manigraph_shared.cells`); ``None``:
    #: the default cell.
    cell: str | None = None

    def __post_init__(self) -> None:
        if self.cell is not None:
            check_cell(self.cell)
        if self.mode not in MODES:
            raise ConfigError("mode", f"'{self.mode}' is not one of {', '.join(MODES)}")
        for name in ("connect", "listen"):
            for endpoint in getattr(self, name):
                if "/" not in endpoint:
                    raise ConfigError(name, f"'{endpoint}' is not an endpoint like tcp/HOST:PORT")
        if self.mode == "client" and not self.connect:
            raise ConfigError("connect", "client mode needs at least one router endpoint")
        if self.wait_seconds is not None and self.wait_seconds < 0:
            raise ConfigError("wait_seconds", "must be >= 0")
        if self.no_stack_after is not None and self.no_stack_after < 0:
            raise ConfigError("no_stack_after", "must be >= 0")
        if self.config_file is not None and not self.config_file.is_file():
            raise ConfigError("config", f"no such file: {self.config_file}")
        self._check_tls()

    @property
    def tls(self) -> bool:
        return self.tls_dir is not None

    def _check_tls(self) -> None:
        endpoints = [("connect", e) for e in self.connect] + [("listen", e) for e in self.listen]
        if self.tls_dir is None:
            if self.tls_identity is not None:
                raise ConfigError("tls_dir", "--tls-identity needs --tls-dir (MANIGRAPH_TLS_DIR)")
            for name, endpoint in endpoints:
                # a Zenoh config file of one's own may carry its TLS settings itself
                if endpoint.startswith("tls/") and self.config_file is None:
                    raise ConfigError(
                        "tls_dir",
                        f"{name} endpoint '{endpoint}' needs --tls-dir and --tls-identity",
                    )
            return
        if not self.tls_identity:
            raise ConfigError(
                "tls_identity", "--tls-dir needs the identity to present (MANIGRAPH_TLS_IDENTITY)"
            )
        for name, endpoint in endpoints:
            if not endpoint.startswith("tls/"):
                raise ConfigError(
                    name, f"'{endpoint}' is not a TLS endpoint; with --tls-dir use tls/HOST:PORT"
                )
        if not self.tls_dir.is_dir():
            raise ConfigError("tls_dir", f"no such directory: {self.tls_dir}")
        for path in tls_files(self.tls_dir, self.tls_identity):
            try:
                with path.open("rb") as handle:
                    handle.read(1)
            except OSError as exc:
                problem = exc.strerror or type(exc).__name__
                raise ConfigError("tls_dir", f"cannot read {path}: {problem}") from None

    def zenoh_json(self) -> dict[str, object]:
        """The settings as Zenoh configuration keys (applied over ``config_file``)."""
        settings: dict[str, object] = {
            "mode": self.mode,
            "scouting/multicast/enabled": self.multicast_scouting,
        }
        if self.connect:
            settings["connect/endpoints"] = list(self.connect)
        if self.listen:
            settings["listen/endpoints"] = list(self.listen)
        if self.mode == "router" and not self.connect and not self.multicast_scouting:
            # Zenoh waits scouting/delay (500 ms) at open for other routers and peers to
            # connect; a router that neither scouts nor connects has nobody to wait for.
            settings["scouting/delay"] = 0
        if self.tls_dir is not None and self.tls_identity is not None:
            ca, cert, key = (str(p.resolve()) for p in tls_files(self.tls_dir, self.tls_identity))
            tls = "transport/link/tls"
            settings[f"{tls}/root_ca_certificate"] = ca
            settings[f"{tls}/enable_mtls"] = True
            # one certificate for both sides: a router listens with it, a client connects with it
            settings[f"{tls}/listen_certificate"] = cert
            settings[f"{tls}/listen_private_key"] = key
            settings[f"{tls}/connect_certificate"] = cert
            settings[f"{tls}/connect_private_key"] = key
        return settings

    def describe(self) -> str:
        where = ",".join(self.listen if self.mode == "router" else self.connect) or "-"
        who = f" as {self.tls_identity}" if self.tls else ""
        cell = f" in cell {self.cell}" if self.cell else ""
        return f"{self.mode} {where}{who}{cell}"


def loopback_endpoint(port: int, tls: bool = False) -> str:
    """The endpoint ``--port`` stands for: the router of ``manigraph up --port PORT``."""
    return f"{'tls' if tls else 'tcp'}/127.0.0.1:{port}"


def add_bus_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("zenoh")
    group.add_argument("-m", "--mode", choices=MODES, help=f"session mode [{ENV['mode']}]")
    group.add_argument(
        "-e",
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="router endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeat for several; "
        f"default {DEFAULT_ROUTER}) [{ENV['connect']}]",
    )
    group.add_argument(
        "--port",
        dest="bus_port",
        type=int,
        metavar="N",
        help="shorthand for the router of `manigraph up --port N`: -e tcp/127.0.0.1:N "
        "(tls/127.0.0.1:N with --tls-dir); the router listens there",
    )
    group.add_argument(
        "-l", "--listen", action="append", help=f"endpoint to listen on [{ENV['listen']}]"
    )
    group.add_argument("-c", "--config", type=Path, help=f"zenoh JSON5 config [{ENV['config']}]")
    group.add_argument(
        "--no-multicast-scouting",
        action="store_true",
        default=None,
        help=f"disable multicast scouting (the default) [{ENV['no_multicast_scouting']}]",
    )
    group.add_argument(
        "--multicast-scouting",
        dest="no_multicast_scouting",
        action="store_false",
        help="enable multicast scouting",
    )
    group.add_argument(
        "--wait-seconds",
        type=float,
        help=f"how long to wait for the router (default: forever) [{ENV['wait_seconds']}]",
    )
    group.add_argument(
        "--tls-dir",
        type=Path,
        help=f"mutual TLS with the certificates of `manigraph certs` in DIR [{ENV['tls_dir']}]",
    )
    group.add_argument(
        "--tls-identity",
        help=f"which certificate in --tls-dir to present, e.g. planner [{ENV['tls_identity']}]",
    )
    group.add_argument(
        "--cell",
        help="the robot cell whose keys to use, manigraph/CELL/... (default: the default "
        f"cell, manigraph/...; docs/scaling.md) [{ENV['cell']}]",
    )


def bus_config_from_args(
    args: argparse.Namespace,
    *,
    mode: str | None = None,
    wait_seconds: float | None = None,
    environ: dict[str, str] | None = None,
    identity: str | None = None,
) -> BusConfig:
    """Flags first, then ``MANIGRAPH_ZENOH_*`` / ``MANIGRAPH_TLS_*`` variables, then the defaults.

    ``mode="router"`` is binding: a router ignores the environment's mode and connect
    endpoints, which in a stack name the router itself. ``identity`` is the TLS identity
    used when a TLS directory is given but no identity (the router: ``router``).
    """
    env = os.environ if environ is None else environ
    is_router = mode == "router"
    identity_default = identity or ("router" if is_router else None)

    def pick(name: str) -> object:
        value = getattr(args, name, None)
        if value is not None or (is_router and name in ("mode", "connect")):
            return value
        return env.get(ENV[name]) or None

    chosen_mode = "router" if is_router else pick("mode") or mode or "client"
    tls_dir = pick("tls_dir")
    port = getattr(args, "bus_port", None)
    connect = _endpoints(pick("connect"))
    listen = _endpoints(pick("listen"))
    if port is not None:
        if not 0 < port <= 65535:
            raise ConfigError("port", f"{port} is not in 1..65535")
        given = "--listen" if is_router else "--connect"
        if getattr(args, given.removeprefix("--"), None):
            raise ConfigError("port", f"give --port or {given}, not both")
        endpoint = loopback_endpoint(port, tls=bool(tls_dir))
        if is_router:
            listen = (endpoint,)
        else:
            connect = (endpoint,)
    default_router = DEFAULT_TLS_ROUTER if tls_dir else DEFAULT_ROUTER
    if not connect and chosen_mode == "client":
        connect = (default_router,)
    if chosen_mode == "router" and not listen:
        listen = (default_router,)
    no_scouting = pick("no_multicast_scouting")
    multicast = _flag_false(no_scouting, ENV["no_multicast_scouting"])
    wait = pick("wait_seconds")
    # A one-shot client (its caller bounds the wait) says at once that nobody listens; a wait
    # asked for with --wait-seconds is waited in full (a script starting its stack beside it).
    no_stack_after = (
        NO_STACK_SECONDS
        if chosen_mode == "client" and wait is None and wait_seconds is not None
        else None
    )
    config = pick("config")
    chosen_identity = pick("tls_identity") or (identity_default if tls_dir else None)
    return BusConfig(
        mode=str(chosen_mode),
        connect=connect,
        listen=listen,
        config_file=Path(str(config)) if config else None,
        multicast_scouting=multicast,
        wait_seconds=_seconds(wait, ENV["wait_seconds"]) if wait is not None else wait_seconds,
        no_stack_after=no_stack_after,
        tls_dir=Path(str(tls_dir)) if tls_dir else None,
        tls_identity=str(chosen_identity) if chosen_identity else None,
        cell=str(cell) if (cell := pick("cell")) else None,
    )


def _endpoints(value: object) -> tuple[str, ...]:
    if value is None:
        return ()
    items = value if isinstance(value, list) else str(value).split(",")
    return tuple(item.strip() for item in items if item.strip())


def _flag_false(value: object, name: str) -> bool:
    """Multicast scouting is on only if explicitly asked for."""
    if value is None or isinstance(value, bool):
        return value is False
    text = str(value).strip().lower()
    if text in ("1", "true", "yes", "on"):
        return False
    if text in ("0", "false", "no", "off"):
        return True
    raise ConfigError(name, f"'{value}' is not a boolean (1/0, true/false)")


def _seconds(value: object, name: str) -> float:
    try:
        return float(str(value))
    except ValueError:
        raise ConfigError(name, f"'{value}' is not a number of seconds") from None
