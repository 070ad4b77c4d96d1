"""TLS settings of the bus: validated at start, with the field or the file named."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from manigraph_shared.bus_config import BusConfig, add_bus_arguments, bus_config_from_args
from manigraph_shared.errors import ConfigError


def from_flags(argv: list[str], environ: dict[str, str], **kwargs: object) -> BusConfig:
    parser = argparse.ArgumentParser()
    add_bus_arguments(parser)
    return bus_config_from_args(parser.parse_args(argv), environ=environ, **kwargs)  # type: ignore[arg-type]


def test_environment_selects_tls_and_the_identity(certs: Path) -> None:
    env = {"MANIGRAPH_TLS_DIR": str(certs), "MANIGRAPH_TLS_IDENTITY": "planner"}
    config = from_flags([], env)
    assert config.connect == ("tls/127.0.0.1:7447",)
    settings = config.zenoh_json()
    assert settings["transport/link/tls/enable_mtls"] is True
    assert settings["transport/link/tls/root_ca_certificate"] == str(certs / "ca.pem")
    assert settings["transport/link/tls/connect_certificate"] == str(certs / "planner.pem")
    assert settings["transport/link/tls/connect_private_key"] == str(certs / "planner.key")
    assert config.describe() == "client tls/127.0.0.1:7447 as planner"


def test_the_router_presents_its_own_certificate_by_default(certs: Path) -> None:
    config = from_flags(["--tls-dir", str(certs)], {}, mode="router")
    assert (config.tls_identity, config.listen) == ("router", ("tls/127.0.0.1:7447",))


def test_plain_tcp_stays_the_default_without_tls_settings() -> None:
    config = from_flags([], {})
    assert not config.tls and config.connect == ("tcp/127.0.0.1:7447",)
    assert not any("tls" in key for key in config.zenoh_json())


@pytest.mark.parametrize(
    ("argv", "field", "problem"),
    [
        (["--tls-dir", "{certs}"], "tls_identity", "needs the identity"),
        (["--tls-identity", "sim"], "tls_dir", "needs --tls-dir"),
        (["-e", "tls/127.0.0.1:1"], "tls_dir", "'tls/127.0.0.1:1' needs --tls-dir"),
        (
            ["--tls-dir", "{certs}", "--tls-identity", "sim", "-e", "tcp/127.0.0.1:1"],
            "connect",
            "'tcp/127.0.0.1:1' is not a TLS endpoint",
        ),
        (["--tls-dir", "/nonexistent", "--tls-identity", "sim"], "tls_dir", "no such directory"),
        (
            ["--tls-dir", "{certs}", "--tls-identity", "nobody"],
            "tls_dir",
            "cannot read {certs}/nobody.pem",
        ),
    ],
)
def test_bad_tls_settings_are_refused_naming_the_field(
    certs: Path, argv: list[str], field: str, problem: str
) -> None:
    argv = [arg.format(certs=certs) for arg in argv]
    with pytest.raises(ConfigError) as error:
        from_flags(argv, {})
    assert error.value.field == field
    assert problem.format(certs=certs) in error.value.problem


def test_a_zenoh_config_file_may_bring_its_own_tls_settings(tmp_path: Path) -> None:
    own = tmp_path / "zenoh.json5"
    own.write_text('{ transport: { link: { tls: { root_ca_certificate: "ca.pem" } } } }')
    config = from_flags(["-c", str(own), "-e", "tls/10.0.0.1:7447"], {})
    assert config.connect == ("tls/10.0.0.1:7447",) and not config.tls


def test_an_unreadable_key_is_refused_naming_the_file(tmp_path: Path, certs: Path) -> None:
    for name in ("ca.pem", "sim.pem"):
        (tmp_path / name).write_bytes((certs / name).read_bytes())
    (tmp_path / "sim.key").mkdir()  # exists, but cannot be read as a file (even by root)
    with pytest.raises(ConfigError, match=f"tls_dir: cannot read {tmp_path}/sim.key"):
        BusConfig(connect=("tls/127.0.0.1:1",), tls_dir=tmp_path, tls_identity="sim")
