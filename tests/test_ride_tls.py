"""``spotfree serve --https``: the generated certificate is kept across restarts while it still fits, and the
user's own certificate is checked before the server starts."""

import pytest
from typer.testing import CliRunner

pytest.importorskip("cryptography")

from spotfree.cli import app  # noqa: E402
from spotfree.errors import InputError  # noqa: E402
from spotfree.ride.tls import kept_certificate, user_certificate  # noqa: E402


def test_the_generated_certificate_is_kept_while_it_fits(tmp_path):
    cert, key = kept_certificate(tmp_path, ["127.0.0.1", "192.168.1.20"])
    first = cert.read_bytes()
    assert kept_certificate(tmp_path, ["192.168.1.20"])[0].read_bytes() == first  # a restart: the same one
    assert user_certificate(cert, key) == (cert, key)
    kept_certificate(tmp_path, ["10.0.0.7"])  # a new address: a new certificate that names it
    assert cert.read_bytes() != first
    cert.write_text("garbage")
    assert kept_certificate(tmp_path, ["10.0.0.7"])[0].read_bytes() != b"garbage"


def test_a_certificate_and_a_key_that_do_not_belong_together_are_refused(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    cert, _ = kept_certificate(one, ["127.0.0.1"])
    _, other_key = kept_certificate(two, ["127.0.0.2"])
    with pytest.raises(InputError, match="--cert"):
        user_certificate(cert, other_key)
    result = CliRunner().invoke(app, ["serve", "--cert", str(cert), "--key", str(other_key), "--database",
                                      str(tmp_path / "r.db")])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert not (tmp_path / "r.db").exists()
    result = CliRunner().invoke(app, ["serve", "--cert", str(cert), "--database", str(tmp_path / "r.db")])
    assert result.exit_code == 2 and "--key" in result.output
