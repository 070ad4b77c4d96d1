"""One way to reach a stack: every client takes `-e/--connect` and `--port` as `up` means it,
and a client that finds no stack says so in one line, at once, naming the endpoint."""

from __future__ import annotations

import argparse
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from manigraph_shared.bus import Bus, NoStackError, zenoh_reason
from manigraph_shared.bus_config import (
    BusConfig,
    add_bus_arguments,
    bus_config_from_args,
)
from manigraph_shared.cli import build_parser
from manigraph_shared.errors import CONFIG_EXIT_CODE, BusError, ConfigError
from manigraph_testkit.testing import free_port
from manigraph_tools.certificates import make_certificates
from manigraph_tools.up_guide import guide

#: The client commands of issue #45, with what each needs besides the bus flags.
CLIENTS = {
    "doctor": [],
    "status": [],
    "run": [],
    "stop": [],
    "resume": [],
    "explain": [],
    "record": [],
    "replay": ["run.mcap"],
    "view": [],
    "demo-ui": [],
    "ros2": [],
}


def parse(*argv: str, mode: str | None = None, wait: float | None = None) -> BusConfig:
    parser = argparse.ArgumentParser()
    add_bus_arguments(parser)
    return bus_config_from_args(
        parser.parse_args(list(argv)), mode=mode, wait_seconds=wait, environ={}
    )


@pytest.mark.parametrize("command", sorted(CLIENTS))
def test_every_client_takes_connect_and_port_as_up_means_them(command: str) -> None:
    def connect(*flags: str) -> tuple[str, ...]:
        argv = [command, *CLIENTS[command], *flags]
        return bus_config_from_args(build_parser(argv).parse_args(argv), environ={}).connect

    assert connect("--port", "7601") == ("tcp/127.0.0.1:7601",)
    assert connect("-e", "tcp/10.0.0.2:7447") == ("tcp/10.0.0.2:7447",)
    assert connect("--connect", "tcp/a:1", "-e", "tcp/b:2") == ("tcp/a:1", "tcp/b:2")


def test_view_serves_foxglove_on_ws_port_and_reaches_the_stack_on_port() -> None:
    argv = ["view", "--port", "7601", "--ws-port", "9000"]
    args = build_parser(argv).parse_args(argv)
    assert args.ws_port == 9000
    assert bus_config_from_args(args, environ={}).connect == ("tcp/127.0.0.1:7601",)


def test_port_is_the_tls_endpoint_on_a_secure_stack(tmp_path: Path) -> None:
    make_certificates(tmp_path, ["client"])
    config = parse("--port", "7601", "--tls-dir", str(tmp_path), "--tls-identity", "client")
    assert config.connect == ("tls/127.0.0.1:7601",)


def test_the_router_listens_on_port() -> None:
    config = parse("--port", "7601", mode="router")
    assert config.listen == ("tcp/127.0.0.1:7601",)
    assert config.connect == ()


@pytest.mark.parametrize(
    ("argv", "mode", "problem"),
    [
        (("--port", "7601", "-e", "tcp/127.0.0.1:7602"), None, "give --port or --connect"),
        (("--port", "7601", "-l", "tcp/127.0.0.1:7602"), "router", "give --port or --listen"),
        (("--port", "0"), None, "0 is not in 1..65535"),
        (("--port", "70000"), None, "70000 is not in 1..65535"),
    ],
)
def test_a_port_that_cannot_be_meant_is_refused(
    argv: tuple[str, ...], mode: str | None, problem: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        parse(*argv, mode=mode)
    assert caught.value.field == "port"
    assert problem in caught.value.problem


def test_one_shot_clients_give_up_at_once_and_services_wait_forever() -> None:
    client = parse(wait=30.0)  # a command like `run`, which bounds its wait
    assert client.no_stack_after is not None and client.no_stack_after < 2.0
    assert parse().no_stack_after is None  # a service (wait_seconds None)
    assert parse("--wait-seconds", "60", wait=30.0).no_stack_after is None  # asked to wait
    assert parse(mode="router", wait=30.0).no_stack_after is None


def test_a_client_with_no_stack_does_not_wait_its_whole_wait() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = BusConfig(connect=(endpoint,), wait_seconds=60.0, no_stack_after=0.5)
    started = time.monotonic()
    with pytest.raises(NoStackError) as caught:
        Bus.open(config)
    assert time.monotonic() - started < 30.0  # far from its 60 s wait, whatever the load
    assert str(caught.value).startswith(f"no stack at {endpoint} (is `manigraph up --port")


def test_a_zenoh_error_reaches_the_user_without_its_rust_source_place() -> None:
    """Something listens but never speaks Zenoh: the client's open times out in Zenoh."""
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen()
        endpoint = f"tcp/127.0.0.1:{silent.getsockname()[1]}"
        config = BusConfig(connect=(endpoint,), wait_seconds=0.0, no_stack_after=0.5)
        with pytest.raises(BusError) as caught:
            Bus.open(config)
    assert endpoint in str(caught.value)
    assert ".rs:" not in str(caught.value) and "cargo" not in str(caught.value)


def test_zenoh_reason_drops_the_rust_place() -> None:
    raw = (
        "Unable to connect to any of [Single(tcp/127.0.0.1:7601)]. Timeout! at "
        "/root/.cargo/git/checkouts/zenoh-9c599d5ef3e0480e/cc83980/zenoh/src/net/runtime/"
        "orchestrator.rs:388."
    )
    assert zenoh_reason(RuntimeError(raw)) == (
        "Unable to connect to any of [Single(tcp/127.0.0.1:7601)]. Timeout!"
    )


def test_a_client_command_with_no_stack_says_so_in_one_line() -> None:
    port = free_port()
    codes = {}
    for command in ("run", "stop", "resume", "doctor"):
        result = subprocess.run(
            [sys.executable, "-m", "manigraph_shared.cli", command, "--port", str(port)],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        assert result.stderr.splitlines() == [
            f"manigraph {command}: no stack at tcp/127.0.0.1:{port} "
            f"(is `manigraph up --port {port}` running?)"
        ]
        codes[command] = result.returncode
    # a runtime failure: neither success nor a refused configuration, and the same for all
    assert len(set(codes.values())) == 1, codes
    assert codes["run"] not in (0, CONFIG_EXIT_CODE)


def test_up_prints_the_connect_line_and_what_to_run_next() -> None:
    lines = guide("tcp/127.0.0.1:7601", None)
    assert lines[0] == "clients: manigraph doctor -e tcp/127.0.0.1:7601"
    commands = " ".join(lines[1:])
    for command in ("status", "run", "stop", "view", "explain"):
        assert f"manigraph {command} -e tcp/127.0.0.1:7601" in commands


def test_on_a_secure_stack_up_names_the_certificates_and_the_tls_flags() -> None:
    certs = Path("/tmp/manigraph-certs-abc")
    lines = guide("tls/127.0.0.1:7601", certs, next_steps=False)
    assert lines == [
        f"clients: manigraph doctor -e tls/127.0.0.1:7601 --tls-dir {certs} --tls-identity client",
        f"certificates: {certs} (made for this run, removed when it stops; docs/security.md)",
    ]
