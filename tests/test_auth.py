"""Run credentials (certificates, modes, loading) and the HMAC tags of telecommands and statuses."""

from __future__ import annotations

import dataclasses
import ipaddress
import json
import os
import stat
import subprocess
import sys

import pytest
from cryptography import x509
from cryptography.x509.oid import NameOID

from fsw.interface import auth, codec
from fsw.interface.messages import AuthTag, RunStatus, Stamp, Telecommand
from fsw.transport.credentials import ROLES, CredentialsError, access_control, load_credentials
from tools.credentials import make_credentials

KEY = bytes(range(32))
OTHER_KEY = bytes(range(1, 33))


def _status(**kw) -> RunStatus:
    base = dict(t_s=1.0, timestamp=Stamp(sec=1, nsec=0), run_id="r1", source="sim", state="end-of-run",
                counts={"sim/measurements": 10})
    base.update(kw)
    return RunStatus(**base)  # type: ignore[arg-type]


# -- HMAC tags -----------------------------------------------------------------------------------
def test_a_signed_message_passes_and_survives_the_wire():
    a = auth.MessageAuthenticator(KEY)
    for msg in (Telecommand(id="c1", command="disable-filter", filter="radio"), _status()):
        signed = a.sign(msg)
        assert signed.auth is not None and len(signed.auth.mac) == 64 and len(signed.auth.nonce) == 32
        assert a.refusal(signed) is None
        assert a.refusal(codec.from_json(type(msg), codec.to_json(signed))) is None


def test_tampered_wrong_key_and_missing_tags_are_refused():
    a = auth.MessageAuthenticator(KEY)
    cmd = a.sign(Telecommand(id="c1", command="disable-filter", filter="radio"))
    assert a.refusal(dataclasses.replace(cmd, filter="fused")) == auth.BAD  # payload changed after signing
    assert a.refusal(dataclasses.replace(cmd, id="c2")) == auth.BAD
    assert a.refusal(auth.MessageAuthenticator(OTHER_KEY).sign(cmd)) == auth.BAD  # someone else's key
    assert a.refusal(dataclasses.replace(cmd, auth=None)) == auth.MISSING
    assert a.refusal(dataclasses.replace(cmd, auth=AuthTag(nonce=cmd.auth.nonce, mac="0" * 64))) == auth.BAD
    # the nonce is covered: a tag moved to another nonce does not pass
    assert a.refusal(dataclasses.replace(cmd, auth=AuthTag(nonce="00" * 16, mac=cmd.auth.mac))) == auth.BAD
    st = a.sign(_status())
    assert a.refusal(dataclasses.replace(st, counts={"sim/measurements": 9})) == auth.BAD
    assert a.refusal(dataclasses.replace(st, state="running")) == auth.BAD


def test_a_tag_is_bound_to_its_message_type():
    """The schema name is part of what is signed: the canonical bytes of two types never coincide."""
    nonce = "ab" * 16
    cmd = Telecommand(id="x", command="status")
    assert auth.canonical_bytes(cmd, nonce).startswith(codec.schema_name(Telecommand).encode() + b"\n" + nonce.encode())
    assert auth.canonical_bytes(_status(), nonce).startswith(codec.schema_name(RunStatus).encode())
    assert b'"auth":null' in auth.canonical_bytes(auth.MessageAuthenticator(KEY).sign(cmd), nonce)


def test_nonces_are_accepted_once_and_remembered_up_to_capacity():
    g = auth.NonceGuard(capacity=3)
    assert g.first_use("a") and not g.first_use("a")
    for n in "bcd":
        assert g.first_use(n)
    assert g.first_use("a")  # evicted: the oldest of more than three
    assert not g.first_use("d")


def test_a_short_key_is_refused():
    with pytest.raises(ValueError):
        auth.MessageAuthenticator(b"short")


# -- credentials ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def creds_dir(tmp_path_factory):
    return make_credentials(tmp_path_factory.mktemp("c") / "credentials")


def test_credentials_are_private_and_hold_one_certificate_per_role(creds_dir):
    assert stat.S_IMODE(creds_dir.stat().st_mode) == 0o700
    names = sorted(p.name for p in creds_dir.iterdir())
    assert names == sorted(["ca.pem", "run.key", *(f"{r}.pem" for r in ROLES), *(f"{r}.key" for r in ROLES)])
    for p in creds_dir.iterdir():
        assert stat.S_IMODE(p.stat().st_mode) == 0o600, p
    ca = x509.load_pem_x509_certificate((creds_dir / "ca.pem").read_bytes())
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    for role in ROLES:
        cert = x509.load_pem_x509_certificate((creds_dir / f"{role}.pem").read_bytes())
        assert cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value == role
        assert cert.issuer == ca.subject
        cert.verify_directly_issued_by(ca)
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        assert san.get_values_for_type(x509.IPAddress) == [ipaddress.ip_address("127.0.0.1")]
    # the CA's private key never reaches the disk: no file holds a key matching ca.pem
    ca_pub = ca.public_key().public_numbers()
    from cryptography.hazmat.primitives.serialization import load_pem_private_key
    for role in ROLES:
        key = load_pem_private_key((creds_dir / f"{role}.key").read_bytes(), None)
        assert key.public_key().public_numbers() != ca_pub
    assert len(bytes.fromhex((creds_dir / "run.key").read_text().strip())) == auth.KEY_BYTES


def test_two_runs_get_different_authorities_and_keys(tmp_path, creds_dir):
    other = make_credentials(tmp_path / "other")
    assert (other / "ca.pem").read_bytes() != (creds_dir / "ca.pem").read_bytes()
    assert (other / "run.key").read_bytes() != (creds_dir / "run.key").read_bytes()


def test_loading_checks_files_and_modes(tmp_path):
    d = make_credentials(tmp_path / "c")
    creds = load_credentials(d, "fsw")
    assert creds.role == "fsw" and creds.certificate.endswith("fsw.pem") and len(creds.run_key) == 32
    with pytest.raises(CredentialsError, match="role"):
        load_credentials(d, "intruder")
    with pytest.raises(CredentialsError, match="not a directory"):
        load_credentials(tmp_path / "missing", "fsw")
    os.chmod(d / "fsw.key", 0o644)
    with pytest.raises(CredentialsError, match=r"fsw.key: mode 0644"):
        load_credentials(d, "fsw")
    os.chmod(d / "fsw.key", 0o600)
    os.chmod(d, 0o755)
    with pytest.raises(CredentialsError, match="mode 0755"):
        load_credentials(d, "fsw")
    os.chmod(d, 0o700)
    (d / "sim.pem").unlink()
    with pytest.raises(CredentialsError, match="sim.pem"):
        load_credentials(d, "sim")
    (d / "run.key").write_text("not hex")
    with pytest.raises(CredentialsError, match="hex"):
        load_credentials(d, "fsw")


def test_the_access_control_list_denies_by_default_and_names_every_role():
    acl = access_control()
    assert acl["enabled"] and acl["default_permission"] == "deny"
    assert {s["id"] for s in acl["subjects"]} == set(ROLES)
    rules = {r["id"]: r for r in acl["rules"]}
    policy = {p["rules"][0]: set(p["subjects"]) for p in acl["policies"]}
    assert policy["command"] == {"operator"} and rules["command"]["key_exprs"] == ["navbank/*/fsw/cmd"]
    assert policy["sim-put"] == {"sim"} and policy["fsw-put"] == {"fsw"}
    assert policy["fsw-serve"] == {"fsw"} and rules["fsw-serve"]["messages"] == ["declare_queryable", "reply"]
    assert policy["ground-serve"] == {"ground"} and policy["subscribe"] == set(ROLES)
    assert all(r["flows"] == ["ingress"] for i, r in rules.items() if i != "egress")


def test_a_bad_credentials_option_is_one_line_and_exit_code_2(tmp_path):
    d = make_credentials(tmp_path / "c")
    os.chmod(d / "run.key", 0o640)
    for args in (["fsw", "--run-id", "r1", "--credentials", str(d)],
                 ["ground", "log", "--run-id", "r1", "--out", str(tmp_path / "x.mcap"), "--credentials", str(tmp_path / "nope")],
                 ["sim", "--run-id", "r1", "--credentials", str(d), "--scenario", "insight-approach"]):
        proc = subprocess.run([sys.executable, "-m", "tools.cli", *args], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, (args, proc.stderr)
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "--credentials" in lines[0] and "Traceback" not in proc.stderr, proc.stderr
    os.chmod(d / "run.key", 0o600)
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "fsw", "--run-id", "r1", "--credentials", str(d),
                           "--listen", "tcp/127.0.0.1:0"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "tls/" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_tags_round_trip_through_the_icd_json():
    signed = auth.MessageAuthenticator(KEY).sign(Telecommand(id="c", command="status"))
    data = json.loads(codec.to_json(signed))
    assert set(data["auth"]) == {"nonce", "mac"}
    assert codec.from_json(Telecommand, json.dumps(data)) == signed


def test_the_credentials_command_makes_a_directory_once(tmp_path):
    d = tmp_path / "hand"
    run = lambda *a: subprocess.run([sys.executable, "-m", "tools.cli", "credentials", *a], capture_output=True,  # noqa: E731
                                    text=True, timeout=120)
    first = run(str(d))
    assert first.returncode == 0, first.stderr
    assert load_credentials(d, "operator").role == "operator"
    again = run(str(d))  # never overwrites the credentials of a run
    assert again.returncode == 2 and len(again.stderr.strip().splitlines()) == 1, again.stderr
    bad = run(str(tmp_path / "x"), "--host", "nope")
    assert bad.returncode == 2 and not (tmp_path / "x").exists(), bad.stderr

