"""The secret between the live view's guard and the Foxglove SDK's server behind it.

The SDK's server listens on a loopback port of its own, which a web page could find by
scanning. Started with :class:`UpstreamSecret`'s key it speaks TLS only; the guard
(:mod:`recorder.live.guard`) pins this run's certificate, and no browser trusts it, so
no page's handshake gets through (see the guard's docstring).
"""

from __future__ import annotations

import datetime
import ipaddress
import logging
import ssl
from dataclasses import dataclass

__all__ = ["UpstreamSecret", "quiet_foreign_handshakes"]

#: The Foxglove SDK's server logs here (through Python's logging) each client it drops.
SDK_SERVER_LOGGER = "foxglove.websocket.server"

_VALID_FOR = datetime.timedelta(days=30)  # longer than any session; made anew each run


@dataclass(frozen=True)
class UpstreamSecret:
    """A TLS key and self-signed certificate for the SDK's server, made for one run and
    trusted by the guard alone (see the module docstring)."""

    cert_pem: bytes
    key_pem: bytes

    @classmethod
    def generate(cls) -> UpstreamSecret:
        from cryptography import x509
        from cryptography.hazmat.primitives import hashes, serialization
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.x509.oid import NameOID

        key = ec.generate_private_key(ec.SECP256R1())
        name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "twopose live upstream")])
        now = datetime.datetime.now(datetime.UTC)
        loopback = x509.IPAddress(ipaddress.ip_address("127.0.0.1"))
        cert = (
            x509.CertificateBuilder()
            .subject_name(name)
            .issuer_name(name)
            .public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + _VALID_FOR)
            .add_extension(x509.SubjectAlternativeName([loopback]), critical=False)
            .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
            .sign(key, hashes.SHA256())
        )
        key_pem = key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,  # the SDK's server takes PKCS#8 only
            serialization.NoEncryption(),
        )
        return cls(cert.public_bytes(serialization.Encoding.PEM), key_pem)

    def client_context(self) -> ssl.SSLContext:
        """What the guard connects with: this certificate, and no other, trusted."""
        return ssl.create_default_context(cadata=self.cert_pem.decode("ascii"))


class _OneLine(logging.Filter):
    """The SDK server's "Dropping client ...: secure handshake failed: ..." (rustls' words
    for a ``ws://`` handshake or a certificate a browser does not trust): a foreign page
    refused, as designed. The first becomes one plain line; the rest are not printed."""

    said = False

    def filter(self, record: logging.LogRecord) -> bool:
        text = record.getMessage()
        if not text.startswith("Dropping client"):
            return True
        if _OneLine.said:
            return False
        _OneLine.said = True
        record.msg, record.args = (
            "the live view's private port dropped a connection that did not speak its TLS "
            "(a web page or a port scan, refused as designed; the recording is not affected); "
            "further ones are dropped without a word",
            (),
        )
        record.levelno, record.levelname = logging.WARNING, "WARNING"
        return True


def quiet_foreign_handshakes() -> None:
    """Install :class:`_OneLine` on the SDK server's logger (once a process)."""
    logger = logging.getLogger(SDK_SERVER_LOGGER)
    if not any(isinstance(f, _OneLine) for f in logger.filters):
        logger.addFilter(_OneLine())
