"""Every log read is bounded (issue 72): a zip member or a gzip log is refused past ``checks.MAX_UNPACKED`` bytes
once uncompressed (a zip by the size it declares, before reading), and a device, FIFO or socket is refused at once
instead of read forever or waited on; on the command line, one line and exit status 2."""

import os
import threading
import time
import zipfile

import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.io import checks, read_recording

runner = CliRunner()
LIMIT = 1 << 20
"""The limit the tests set: 1 MiB."""


def _bomb(path, member: str = "Accelerometer.csv", size: int = 2 * LIMIT):
    """A zip export whose member holds ``size`` bytes that compress to a few kilobytes."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("Metadata.csv", "version,device name,recording time,platform\n1,x,2024,android\n")
        archive.writestr(member, b"time,seconds_elapsed,z,y,x\n" + b"0" * size)
    return path


def test_a_zip_member_past_the_limit_is_refused_before_it_is_read(tmp_path, monkeypatch):
    monkeypatch.setattr(checks, "MAX_UNPACKED", LIMIT)
    bomb = _bomb(tmp_path / "bomb.zip")
    assert bomb.stat().st_size < LIMIT // 100
    with pytest.raises(InputError, match=r"bomb\.zip:Accelerometer\.csv: holds 2097179 bytes once uncompressed, "
                                         r"more than 0\.000976562 GiB; split the log"):
        read_recording(str(bomb))
    result = runner.invoke(app, ["features", str(bomb), "-o", str(tmp_path / "f.csv")])
    assert result.exit_code == 2 and "once uncompressed" in result.output
    assert len(result.output.strip().splitlines()) == 1


def test_a_folder_member_or_a_plain_log_past_the_limit_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(checks, "MAX_UNPACKED", LIMIT)
    big = tmp_path / "big.csv"
    big.write_bytes(b"time,ax,ay,az,gx,gy,gz\n" + b"0" * (2 * LIMIT))
    with pytest.raises(InputError, match=r"big\.csv: is over .* GiB; split the log"):
        read_recording(str(big))
    folder = tmp_path / "export"
    with zipfile.ZipFile(_bomb(tmp_path / "e.zip")) as archive:
        archive.extractall(folder)
    with pytest.raises(InputError, match=r"Accelerometer\.csv: holds more than .* GiB; split the log"):
        read_recording(str(folder))


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_a_device_is_refused_not_read_forever(device, tmp_path):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    started = time.monotonic()
    with pytest.raises(InputError, match="not a regular file"):
        read_recording(device)
    link = tmp_path / "ride.zip"
    link.symlink_to(device)
    with pytest.raises(InputError, match="not a regular file"):
        read_recording(str(link))
    assert time.monotonic() - started < 5


def test_a_fifo_is_refused_not_waited_on(tmp_path):
    fifo = tmp_path / "ride.csv"
    os.mkfifo(fifo)
    answers = []

    def read():  # in a thread: a reader that waits on the FIFO fails the test rather than hang it
        try:
            read_recording(str(fifo))
        except InputError as exc:
            answers.append(str(exc))
    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(10)
    assert len(answers) == 1 and "not a regular file" in answers[0] and "\n" not in answers[0]
    result = runner.invoke(app, ["serve", "--replay", str(fifo), "--database", str(tmp_path / "r.db"), "--port",
                                 "1"])
    assert result.exit_code == 2 and "not a regular file" in result.output
