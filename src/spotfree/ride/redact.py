"""Store locations as they may be shown: in an answer, an error message or a log line.

A PostgreSQL URL may hold a password (``postgresql://user:secret@host/db``) or pass one as a query parameter
(``?password=secret``, libpq's keyword); :func:`redact_location` replaces both by ``***``, and :func:`scrub` does
the same in a text that may quote the URL or a piece of it (a driver's error message). A SQLite path is shown as it
is.
"""

from __future__ import annotations

from urllib.parse import parse_qsl, unquote, urlencode, urlsplit, urlunsplit

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


def scrub(text: str, location: str) -> str:
    """``text`` with ``location`` shown as :func:`redact_location` shows it and every secret of ``location`` (its
    password as written and percent-decoded, the values of its secret query keys) replaced by :data:`HIDDEN`."""
    if "://" not in location:
        return text
    text = text.replace(location, redact_location(location))
    rest = location.split("://", 1)[1]
    secrets = []
    if "@" in rest:
        secrets.append(rest[:rest.rfind("@")].partition(":")[2])
    if "?" in rest:
        secrets += [v for k, v in parse_qsl(rest.split("?", 1)[1], keep_blank_values=True)
                    if k.lower() in _SECRET_KEYS]
    for secret in sorted({s for raw in secrets for s in (raw, unquote(raw)) if s}, key=len, reverse=True):
        text = text.replace(secret, HIDDEN)
    return text
