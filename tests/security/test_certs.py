"""`manigraph certs`: a local CA and one certificate per identity, never overwritten by accident."""

from __future__ import annotations

import re
import stat
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from manigraph_shared.cli import main
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError
from manigraph_tools.certificates import IDENTITIES, make_certificates


def load(path: Path) -> x509.Certificate:
    return x509.load_pem_x509_certificate(path.read_bytes())


def common_name(cert: x509.Certificate) -> str:
    return str(cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value)


def test_every_identity_gets_a_certificate_signed_by_the_ca(certs: Path) -> None:
    ca = load(certs / "ca.pem")
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    for identity in IDENTITIES:
        cert = load(certs / f"{identity}.pem")
        assert common_name(cert) == identity
        cert.verify_directly_issued_by(ca)
        usage = cert.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
        assert {ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH} <= set(usage)
        names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        assert identity in names.get_values_for_type(x509.DNSName)
        assert stat.S_IMODE((certs / f"{identity}.key").stat().st_mode) == 0o600
    assert not list(certs.glob("ca.key")), "the CA's private key must not be kept"


def test_extra_hosts_are_in_every_certificate(tmp_path: Path) -> None:
    make_certificates(tmp_path, ["router"], hosts=["manigraph.lan", "10.0.0.7"])
    names = load(tmp_path / "router.pem").extensions.get_extension_for_class(
        x509.SubjectAlternativeName
    )
    assert "manigraph.lan" in names.value.get_values_for_type(x509.DNSName)
    assert [str(ip) for ip in names.value.get_values_for_type(x509.IPAddress)] == [
        "127.0.0.1",
        "10.0.0.7",
    ]


def test_an_existing_set_is_not_overwritten_without_force(tmp_path: Path) -> None:
    make_certificates(tmp_path, ["sim"])
    before = (tmp_path / "sim.pem").read_bytes()
    with pytest.raises(ConfigError, match=r"ca\.pem exists; pass --force") as error:
        make_certificates(tmp_path, ["sim"])
    assert error.value.field == "out"
    assert (tmp_path / "sim.pem").read_bytes() == before
    make_certificates(tmp_path, ["sim"], force=True)
    assert (tmp_path / "sim.pem").read_bytes() != before


def test_bad_identities_and_validity_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=re.escape("identity: '../x'")):
        make_certificates(tmp_path, ["../x"])
    with pytest.raises(ConfigError, match="days: 0 must be >= 1"):
        make_certificates(tmp_path, ["sim"], days=0)
    assert not list(tmp_path.iterdir())


def test_the_command_refuses_to_overwrite_and_keeps_an_existing_set(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "certs"
    assert main(["certs", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["ca.pem"] + [f"{i}.{ext}" for i in IDENTITIES for ext in ("pem", "key")]
    )
    before = (out / "planner.pem").read_bytes()
    assert main(["certs", "--out", str(out)]) == CONFIG_EXIT_CODE
    assert f"{out}/ca.pem exists; pass --force" in capsys.readouterr().err
    assert main(["certs", "--out", str(out), "--keep-existing"]) == 0
    assert (out / "planner.pem").read_bytes() == before
    (out / "planner.key").unlink()  # an incomplete set is not kept: it is refused
    assert main(["certs", "--out", str(out), "--keep-existing"]) == CONFIG_EXIT_CODE
    assert main(["certs", "--out", str(out), "--force"]) == 0
    assert (out / "planner.pem").read_bytes() != before
