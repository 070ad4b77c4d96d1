from __future__ import annotations

import argparse

import pytest

from manigraph_shared.bus_config import (
    DEFAULT_ROUTER,
    BusConfig,
    add_bus_arguments,
    bus_config_from_args,
)
from manigraph_shared.errors import ConfigError


def parse(*argv: str, env: dict[str, str] | None = None, mode: str | None = None) -> BusConfig:
    parser = argparse.ArgumentParser()
    add_bus_arguments(parser)
    return bus_config_from_args(parser.parse_args(list(argv)), mode=mode, environ=env or {})


def test_default_is_a_client_of_the_local_router_without_multicast() -> None:
    config = parse()
    assert config.mode == "client"
    assert config.connect == (DEFAULT_ROUTER,)
    assert config.multicast_scouting is False
    assert config.wait_seconds is None  # services wait for their router forever


def test_environment_configures_what_flags_do_not() -> None:
    env = {
        "MANIGRAPH_ZENOH_CONNECT": "tcp/router:7447,tcp/backup:7447",
        "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "0",
    }
    config = parse(env=env)
    assert config.connect == ("tcp/router:7447", "tcp/backup:7447")
    assert config.multicast_scouting is True


def test_flags_win_over_the_environment() -> None:
    env = {"MANIGRAPH_ZENOH_CONNECT": "tcp/router:7447", "MANIGRAPH_ZENOH_MODE": "peer"}
    config = parse("--mode", "client", "-e", "tcp/127.0.0.1:9000", env=env)
    assert config.mode == "client"
    assert config.connect == ("tcp/127.0.0.1:9000",)


def test_router_listens_on_the_default_endpoint_whatever_the_environment_says() -> None:
    env = {"MANIGRAPH_ZENOH_MODE": "client", "MANIGRAPH_ZENOH_CONNECT": DEFAULT_ROUTER}
    config = parse(mode="router", env=env)
    assert config.connect == ()
    assert config.listen == (DEFAULT_ROUTER,)
    assert config.zenoh_json()["mode"] == "router"


@pytest.mark.parametrize(
    ("argv", "env", "field"),
    [
        ((), {"MANIGRAPH_ZENOH_MODE": "satellite"}, "mode"),
        (("-e", "localhost"), {}, "connect"),
        (
            (),
            {"MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "maybe"},
            "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING",
        ),
        ((), {"MANIGRAPH_ZENOH_WAIT_SECONDS": "soon"}, "MANIGRAPH_ZENOH_WAIT_SECONDS"),
        (("--config", "/nonexistent/zenoh.json5"), {}, "config"),
    ],
)
def test_bad_values_name_the_field(argv: tuple[str, ...], env: dict[str, str], field: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse(*argv, env=env)
    assert caught.value.field == field


def test_a_lone_router_opens_without_waiting_for_other_routers() -> None:
    """Zenoh's scouting delay (500 ms at open) is for routers that connect or scout."""
    lone = BusConfig(mode="router", connect=(), listen=(DEFAULT_ROUTER,))
    assert lone.zenoh_json()["scouting/delay"] == 0
    linked = BusConfig(mode="router", connect=("tcp/10.0.0.2:7447",), listen=(DEFAULT_ROUTER,))
    assert "scouting/delay" not in linked.zenoh_json()
    scouting = BusConfig(mode="router", connect=(), multicast_scouting=True)
    assert "scouting/delay" not in scouting.zenoh_json()
