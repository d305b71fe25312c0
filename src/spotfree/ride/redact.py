"""Store locations as they may be shown: in an answer, an error message or a log line.

A PostgreSQL URL may hold a password (``postgresql://user:secret@host/db``) or pass one as a query parameter
(``?password=secret``, libpq's keyword); :func:`redact_location` replaces both by ``***``. A SQLite path is shown
as it is.
"""

from __future__ import annotations

from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit

HIDDEN = "***"
_SECRET_KEYS = {"password", "sslpassword", "passfile", "sslkey"}


def redact_location(location: str) -> str:
    """``location`` with any password replaced by :data:`HIDDEN`; a path or a URL without one is unchanged."""
    if "://" not in location:
        return location
    try:
        parts = urlsplit(location)
        netloc = parts.netloc
        if "@" in netloc:
            credentials, _, host = netloc.rpartition("@")
            user, colon, _ = credentials.partition(":")
            netloc = f"{user}:{HIDDEN}@{host}" if colon else f"{user}@{host}"
        query = parts.query
        if query:
            pairs = parse_qsl(query, keep_blank_values=True)
            query = urlencode([(k, HIDDEN if k.lower() in _SECRET_KEYS else v) for k, v in pairs], safe="*")
        return urlunsplit((parts.scheme, netloc, parts.path, query, parts.fragment))
    except ValueError:
        scheme = location.split("://", 1)[0]
        return f"{scheme}://{HIDDEN}"
