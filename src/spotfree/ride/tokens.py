"""Device and operator tokens and enrolment codes: random bytes shown once, only their SHA-256 kept by the store.

A token carries 256 bits of entropy (an enrolment code 72 bits, and it expires and has few uses), so a stolen
hash cannot be inverted by guessing and a slow password hash (scrypt, bcrypt) would add cost to every request
without adding safety; SHA-256 lets the store find the device by an indexed lookup of the hash.
"""

from __future__ import annotations

import hashlib
import secrets

TOKEN_BYTES = 32


def new_token(nbytes: int = TOKEN_BYTES) -> str:
    """A fresh token: ``nbytes`` random bytes from the OS, URL-safe base64 (43 characters for the default 32)."""
    return secrets.token_urlsafe(nbytes)


def token_hash(token: str) -> str:
    """The hex SHA-256 of ``token`` as stored in the ``devices`` table."""
    return hashlib.sha256(token.encode("utf-8")).hexdigest()
