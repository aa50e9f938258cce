"""The organizer's keys for a Dask cluster: a certificate authority of its own, and a
certificate and key for the scheduler, the workers and the client, so that the cluster's
TLS admits only machines the organizer gave a key to (mutual TLS, docs/cluster.md).

The CA's own key is used once, to sign the three certificates, and never written: nobody can
sign a fourth. Keys are written 0600 into a new folder made 0700; certificates 0644 beside
them. Dask checks a peer's certificate against the CA, not its host name, so one worker
certificate serves every worker machine.
"""

from __future__ import annotations

import datetime
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from referee.errors import UserError

ROLES = ("scheduler", "worker", "client")
CA_FILE = "ca.pem"
VALID_DAYS = 365


def cert_file(role: str) -> str:
    """The file name of a role's certificate in a keys folder."""
    return f"{role}.pem"


def key_file(role: str) -> str:
    """The file name of a role's private key in a keys folder."""
    return f"{role}-key.pem"


@dataclass(frozen=True)
class Credentials:
    """One role's TLS material as PEM text: the CA certificate, its own certificate and key."""

    ca: str
    cert: str
    key: str


def _write(path: Path, data: bytes, mode: int) -> None:
    fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, mode)
    with os.fdopen(fd, "wb") as f:
        f.write(data)


def make_keys(folder: Path) -> list[Path]:
    """Make a CA and each role's certificate and key in `folder`, which must not exist yet
    (its parent must); return the files written. UserError (one line) otherwise."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    if folder.exists() or folder.is_symlink():
        raise UserError(f"{folder}: already exists; give a new folder for the keys")
    if not folder.resolve().parent.is_dir():
        raise UserError(f"{folder}: the folder above it does not exist")
    now = datetime.datetime.now(datetime.UTC)
    until = now + datetime.timedelta(days=VALID_DAYS)

    def name(common: str) -> x509.Name:
        return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common)])

    def builder(subject: str, issuer: str, public: ec.EllipticCurvePublicKey) -> x509.CertificateBuilder:
        return (
            x509.CertificateBuilder()
            .subject_name(name(subject))
            .issuer_name(name(issuer))
            .public_key(public)
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))  # a worker's clock a little behind
            .not_valid_after(until)
        )

    def pem_key(key: ec.EllipticCurvePrivateKey) -> bytes:
        return key.private_bytes(
            serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
        )

    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_name = "laserarena organizer CA"
    ca = (
        builder(ca_name, ca_name, ca_key.public_key())
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(
            x509.KeyUsage(False, False, False, False, False, True, True, False, False), critical=True
        )  # certificate and CRL signing only
        .sign(ca_key, hashes.SHA256())
    )
    folder.mkdir(mode=0o700)
    os.chmod(folder, 0o700)
    written = [folder / CA_FILE]
    _write(written[0], ca.public_bytes(serialization.Encoding.PEM), 0o644)
    usages = [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]  # each role both listens and connects
    for role in ROLES:
        key = ec.generate_private_key(ec.SECP256R1())
        cert = (
            builder(f"laserarena {role}", ca_name, key.public_key())
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(x509.ExtendedKeyUsage(usages), critical=False)
            .sign(ca_key, hashes.SHA256())
        )
        _write(folder / key_file(role), pem_key(key), 0o600)
        _write(folder / cert_file(role), cert.public_bytes(serialization.Encoding.PEM), 0o644)
        written += [folder / cert_file(role), folder / key_file(role)]
    return written


def credentials(folder: Path, role: str = "client") -> Credentials:
    """A role's material read from a keys folder `make_keys` wrote; UserError (one line) for a
    file that is missing or a key that others may read."""
    texts = []
    for name in (CA_FILE, cert_file(role), key_file(role)):
        path = folder / name
        try:
            texts.append(path.read_text(encoding="ascii"))
        except (OSError, UnicodeDecodeError) as e:
            raise UserError(
                f"--cluster-keys {folder}: cannot read {name} ({getattr(e, 'strerror', None) or e}); "
                "make the keys with `laserarena cluster-keys DIR`"
            ) from None
    if os.stat(folder / key_file(role)).st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise UserError(f"--cluster-keys {folder}: {key_file(role)} may be read by others; chmod 600 it")
    return Credentials(*texts)
