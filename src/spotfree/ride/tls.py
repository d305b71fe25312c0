"""A self-signed certificate for ``spotfree serve --https``: phones give a page motion and location only in a
secure context, and a phone on the LAN reaches the server by its address, not as localhost.

The certificate (ECDSA P-256, SHA-256, valid for :data:`DAYS` days) names ``localhost``, the host name and every
address given; the phone's browser warns once that nobody vouches for it, and the rider accepts it. It is kept
across restarts while it names the same addresses and stays valid (:func:`kept_certificate`), so a phone is not
asked again. ``--cert`` and ``--key`` use the user's own certificate instead (:func:`user_certificate`).
"""

from __future__ import annotations

import datetime
import ipaddress
import socket
from pathlib import Path

DAYS = 365


def self_signed_certificate(folder: Path, hosts: list[str]) -> tuple[Path, Path]:
    """Write ``cert.pem`` and ``key.pem`` into ``folder`` for ``hosts`` (names or IP addresses); returns both paths."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    names: list[x509.GeneralName] = [x509.DNSName("localhost"), x509.DNSName(socket.gethostname())]
    for host in hosts:
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host)))
        except ValueError:
            names.append(x509.DNSName(host))
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "spotfree serve")])
    now = datetime.datetime.now(datetime.timezone.utc)
    cert = (x509.CertificateBuilder().subject_name(subject).issuer_name(subject).public_key(key.public_key())
            .serial_number(x509.random_serial_number()).not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=DAYS))
            .add_extension(x509.SubjectAlternativeName(list(dict.fromkeys(names))), critical=False)
            .sign(key, hashes.SHA256()))
    folder.mkdir(parents=True, exist_ok=True)
    cert_path, key_path = folder / "cert.pem", folder / "key.pem"
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))
    key_path.chmod(0o600)
    return cert_path, key_path


def kept_certificate(folder: Path, hosts: list[str]) -> tuple[Path, Path]:
    """``cert.pem`` and ``key.pem`` of ``folder`` when they exist, load, name every one of ``hosts`` and stay valid
    for more than a day (so that phones that accepted the certificate are not asked again after a restart);
    else a new pair (:func:`self_signed_certificate`)."""
    from cryptography import x509

    cert_path, key_path = folder / "cert.pem", folder / "key.pem"
    try:
        cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
        names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        known = {str(n) for n in names.get_values_for_type(x509.IPAddress)} | set(names.get_values_for_type(
            x509.DNSName))
        left = cert.not_valid_after_utc - datetime.datetime.now(datetime.timezone.utc)
        if key_path.exists() and set(hosts) <= known and left > datetime.timedelta(days=1):
            return cert_path, key_path
    except (OSError, ValueError, x509.ExtensionNotFound):
        pass
    return self_signed_certificate(folder, hosts)


def user_certificate(cert: Path, key: Path) -> tuple[Path, Path]:
    """The user's own certificate chain and private key (PEM), checked to load together (InputError, one line)."""
    import ssl

    from spotfree.errors import InputError

    try:
        ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(cert, key)
    except (OSError, ssl.SSLError) as exc:
        reason = " ".join(str(getattr(exc, "strerror", None) or exc).split())
        raise InputError(f"--cert {cert} --key {key}: not a certificate and its private key ({reason}); give PEM "
                         "files that belong together") from None
    return cert, key


def lan_addresses() -> list[str]:
    """The machine's own IPv4 addresses (for the certificate and the printed link); no packet is sent."""
    found = {"127.0.0.1"}
    try:
        for info in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET):
            found.add(info[4][0])
    except OSError:
        pass
    return sorted(found)
