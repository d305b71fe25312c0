"""The ride store's PostgreSQL connection (psycopg 3): the same SQL as SQLite, ``?`` placeholders turned into
psycopg's ``%s``. Install the driver with ``pip install 'spotfree[postgres]'``."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from spotfree.errors import InputError
from spotfree.ride.redact import redact_location, scrub


class PostgresConnection:
    """One autocommit psycopg connection; :meth:`transaction` is ``BEGIN`` ... ``COMMIT`` (ROLLBACK on error)."""

    def __init__(self, url: str):
        try:
            import psycopg
        except ImportError:
            raise InputError(f"{redact_location(url)}: PostgreSQL needs the psycopg driver; "
                             "pip install 'spotfree[postgres]'") from None
        self.url = url
        try:
            self._connection = psycopg.connect(url, autocommit=True)
        except psycopg.Error as exc:
            first = scrub(str(exc).strip().splitlines()[0], url) if str(exc).strip() else type(exc).__name__
            raise InputError(f"{redact_location(url)}: cannot connect ({first}); check the URL and that the server "
                             "runs") from None

    @contextmanager
    def transaction(self) -> Iterator["_Cursor"]:
        with self._connection.transaction(), self._connection.cursor() as cursor:
            yield _Cursor(cursor)

    def query(self, sql: str, params: tuple) -> list[tuple]:
        with self._connection.cursor() as cursor:
            return cursor.execute(_placeholders(sql), params).fetchall()

    def close(self) -> None:
        self._connection.close()


class _Cursor:
    """A psycopg cursor that takes the store's ``?`` placeholders."""

    def __init__(self, cursor):
        self._cursor = cursor

    def execute(self, sql: str, params: tuple = ()):
        return self._cursor.execute(_placeholders(sql), params)

    def executemany(self, sql: str, rows: list[tuple]) -> None:
        self._cursor.executemany(_placeholders(sql), rows)


def _placeholders(sql: str) -> str:
    """The store's SQL never holds a literal ``?`` or ``%``, so a plain replacement is exact."""
    return sql.replace("?", "%s")
