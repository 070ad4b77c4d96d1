"""``manigraph certs``: a local certificate authority and one certificate per bus identity.

The router and every service authenticate each other with mutual TLS; the router's access
control (``manigraph_tools.access``) then grants each connection what its certificate's
common name (CN) may do. This module writes, into one directory::

    ca.pem                     the CA certificate every party trusts
    <identity>.pem             the identity's certificate, CN = <identity>, signed by the CA
    <identity>.key             its private key (mode 0600)

The CA's private key is never written: once every certificate is signed it is discarded, so a
leaked certificate directory cannot be used to mint new identities. Adding an identity means
making a fresh set (``--force``) and restarting the stack.

Keys are ECDSA P-256 (small, fast handshakes, supported by Zenoh's rustls). Every certificate
carries the subject alternative names ``<identity>``, ``localhost`` and ``127.0.0.1`` (plus
``--host`` names), since Zenoh clients check the router's name on connect: ``tls/router:7447``
in compose, ``tls/127.0.0.1:<port>`` on one machine. The ``cryptography`` package is used
rather than the ``openssl`` command because it is a locked Python dependency available in
every image and on every OS, while the command-line tool is not (slim images lack it).
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from manigraph_shared.bus_config import TLS_CA_FILE, tls_files
from manigraph_shared.errors import ConfigError

#: Every identity on the bus; the access-control table grants each one its rights.
IDENTITIES = (
    "router",
    "sim",
    "perception",
    "planner",
    "skills",
    "recorder",
    "view",
    "client",
    "demo-ui",
)
DEFAULT_DAYS = 365


@dataclass(frozen=True)
class CertificateSet:
    directory: Path
    identities: tuple[str, ...]

    @property
    def ca(self) -> Path:
        return self.directory / TLS_CA_FILE

    def files(self) -> list[Path]:
        paths = [self.ca]
        for identity in self.identities:
            paths += list(tls_files(self.directory, identity)[1:])
        return paths

    def complete(self) -> bool:
        return all(path.is_file() for path in self.files())


def make_certificates(
    directory: Path,
    identities: Sequence[str] = IDENTITIES,
    *,
    hosts: Iterable[str] = (),
    days: int = DEFAULT_DAYS,
    force: bool = False,
) -> CertificateSet:
    """Write a CA and one certificate per identity into ``directory``.

    Refuses (``ConfigError`` naming the file) to overwrite an existing file unless ``force``.
    """
    if days < 1:
        raise ConfigError("days", f"{days} must be >= 1")
    for identity in identities:
        plain = identity.replace("-", "").replace("_", "").replace(".", "")
        if not identity or not plain.isalnum() or identity[0] == "." or identity[-1] == ".":
            raise ConfigError(
                "identity", f"'{identity}' must be letters, digits, '-', '_' or '.' inside"
            )
    wanted = CertificateSet(directory, tuple(dict.fromkeys(identities)))
    if not force:
        for path in wanted.files():
            if path.exists():
                raise ConfigError("out", f"{path} exists; pass --force to replace the whole set")
    directory.mkdir(parents=True, exist_ok=True)
    now = dt.datetime.now(dt.UTC) - dt.timedelta(minutes=5)  # tolerate small clock skew
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "manigraph local CA")])
    ca_cert = (
        _builder(ca_name, ca_name, ca_key.public_key(), now, days)
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(_key_usage(ca=True), critical=True)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(ca_key.public_key()), False)
        .sign(ca_key, hashes.SHA256())
    )
    _write(wanted.ca, ca_cert.public_bytes(serialization.Encoding.PEM), private=False)
    extra_hosts = tuple(hosts)
    for identity in wanted.identities:
        key = ec.generate_private_key(ec.SECP256R1())
        name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, identity)])
        cert = (
            _builder(name, ca_name, key.public_key(), now, days)
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(_key_usage(ca=False), critical=True)
            .add_extension(
                x509.ExtendedKeyUsage(
                    [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
                ),
                critical=False,
            )
            .add_extension(_alt_names((identity, "localhost", "127.0.0.1", *extra_hosts)), False)
            .add_extension(
                x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()), False
            )
            .sign(ca_key, hashes.SHA256())
        )
        _, cert_path, key_path = tls_files(directory, identity)
        _write(cert_path, cert.public_bytes(serialization.Encoding.PEM), private=False)
        key_pem = key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
        _write(key_path, key_pem, private=True)
    return wanted


def _builder(
    subject: x509.Name,
    issuer: x509.Name,
    public_key: ec.EllipticCurvePublicKey,
    now: dt.datetime,
    days: int,
) -> x509.CertificateBuilder:
    return (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(issuer)
        .public_key(public_key)
        .serial_number(x509.random_serial_number())
        .not_valid_before(now)
        .not_valid_after(now + dt.timedelta(days=days))
    )


def _key_usage(ca: bool) -> x509.KeyUsage:
    return x509.KeyUsage(
        digital_signature=not ca,
        content_commitment=False,
        key_encipherment=False,
        data_encipherment=False,
        key_agreement=False,
        key_cert_sign=ca,
        crl_sign=ca,
        encipher_only=False,
        decipher_only=False,
    )


def _alt_names(hosts: Iterable[str]) -> x509.SubjectAlternativeName:
    names: list[x509.GeneralName] = []
    for host in dict.fromkeys(hosts):
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host)))
        except ValueError:
            names.append(x509.DNSName(host))
    return x509.SubjectAlternativeName(names)


def _write(path: Path, data: bytes, private: bool) -> None:
    """Write atomically; private keys are created 0600 so they are never readable by others."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.unlink(missing_ok=True)
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600 if private else 0o644)
    with os.fdopen(fd, "wb") as handle:
        handle.write(data)
    tmp.replace(path)
