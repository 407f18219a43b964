"""Making a run's credentials: a fresh certificate authority and one certificate per role.

``navbank run`` calls :func:`make_credentials` before it starts the processes; the layout and the
file modes are those :func:`fsw.transport.credentials.load_credentials` checks. The CA's private
key lives only in memory while the role certificates are issued, so no one — not even the run's own
processes — can issue another certificate of this run afterwards. Keys are ECDSA P-256; certificates
are valid for ``days`` (a run that outlives them must be restarted with new credentials).
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import os
import secrets
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from fsw.interface.auth import KEY_BYTES
from fsw.transport.credentials import CA_FILE, KEY_FILE, ROLES


def _write_private(path: Path, data: bytes) -> None:
    """Create ``path`` readable by this user only — from the start, not chmod'ed afterwards."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)


def _name(cn: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, cn)])


def make_credentials(directory: str | os.PathLike, *, roles: tuple[str, ...] = ROLES, days: float = 7.0,
                     host: str = "127.0.0.1") -> Path:
    """Write a new credentials directory (it must not exist yet; mode 0700, files 0600)."""
    ip = ipaddress.ip_address(host)  # a bad address fails before anything is written
    d = Path(directory)
    d.mkdir(mode=0o700, parents=False)
    os.chmod(d, 0o700)  # mkdir's mode is filtered by the umask
    now = dt.datetime.now(dt.timezone.utc) - dt.timedelta(minutes=5)  # tolerate small clock steps
    until = now + dt.timedelta(days=days)
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_name = _name(f"navbank run CA {secrets.token_hex(4)}")
    ca = (x509.CertificateBuilder().subject_name(ca_name).issuer_name(ca_name).public_key(ca_key.public_key())
          .serial_number(x509.random_serial_number()).not_valid_before(now).not_valid_after(until)
          .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
          .add_extension(x509.KeyUsage(digital_signature=False, content_commitment=False, key_encipherment=False,
                                       data_encipherment=False, key_agreement=False, key_cert_sign=True,
                                       crl_sign=True, encipher_only=False, decipher_only=False), critical=True)
          .sign(ca_key, hashes.SHA256()))
    _write_private(d / CA_FILE, ca.public_bytes(serialization.Encoding.PEM))
    for role in roles:
        key = ec.generate_private_key(ec.SECP256R1())
        cert = (x509.CertificateBuilder().subject_name(_name(role)).issuer_name(ca_name).public_key(key.public_key())
                .serial_number(x509.random_serial_number()).not_valid_before(now).not_valid_after(until)
                .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                .add_extension(x509.SubjectAlternativeName([x509.IPAddress(ip)]), critical=False)
                .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
                               critical=False)
                .sign(ca_key, hashes.SHA256()))
        _write_private(d / f"{role}.pem", cert.public_bytes(serialization.Encoding.PEM))
        _write_private(d / f"{role}.key", key.private_bytes(serialization.Encoding.PEM,
                                                            serialization.PrivateFormat.PKCS8,
                                                            serialization.NoEncryption()))
    _write_private(d / KEY_FILE, (secrets.token_hex(KEY_BYTES) + "\n").encode())
    return d
