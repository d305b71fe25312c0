"""Where ``-o`` writes (``spotfree.io.checks.replacing``): a regular file replaced at once, a symbolic link's file
written (the link kept), a FIFO or a character device written in place, a folder refused in one line."""

import os
import stat
import threading

import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.io.checks import write_text

runner = CliRunner()


def test_a_symlinks_file_is_written_and_the_link_kept(tmp_path):
    (tmp_path / "real.csv").write_text("old\n")
    (tmp_path / "link.csv").symlink_to("real.csv")
    write_text(tmp_path / "link.csv", "new\n")
    assert (tmp_path / "link.csv").is_symlink() and (tmp_path / "real.csv").read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "real.csv"]  # no temporary file left
    (tmp_path / "dangling.csv").symlink_to("made.csv")
    write_text(tmp_path / "dangling.csv", "x\n")
    assert (tmp_path / "dangling.csv").is_symlink() and (tmp_path / "made.csv").read_text() == "x\n"


@pytest.fixture()
def no_replace(monkeypatch):
    """``os.replace`` refused: a writer that would replace a device fails the test instead of the device."""
    def refused(*args):
        raise AssertionError(f"os.replace{args}: a device would have been replaced by a file")
    monkeypatch.setattr(os, "replace", refused)


def test_a_fifo_and_a_character_device_are_written_in_place(tmp_path, no_replace):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()), daemon=True)
    reader.start()
    write_text(fifo, "a,b\n1,2\n")
    reader.join(10)
    assert got == ["a,b\n1,2\n"] and stat.S_ISFIFO(os.stat(fifo).st_mode)
    write_text("/dev/null", "x\n")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert list(tmp_path.iterdir()) == [fifo]


def test_a_folder_is_refused_in_one_line(tmp_path):
    with pytest.raises(InputError, match="is a folder; give the name of a file"):
        write_text(tmp_path, "x\n")
    result = runner.invoke(app, ["simulate", "normal-braking", "--repeats", "1", "-o", str(tmp_path)])
    assert result.exit_code == 2 and "is a folder" in result.output and ".tmp" not in result.output
    assert list(tmp_path.iterdir()) == []


def test_a_write_error_names_the_target(tmp_path, no_replace):
    full = "/dev/full"
    if not os.path.exists(full):
        pytest.skip("no /dev/full")
    with pytest.raises(OSError) as failed:
        write_text(full, "x\n")
    assert failed.value.filename == full and failed.value.strerror == os.strerror(28)  # ENOSPC
    result = runner.invoke(app, ["simulate", "normal-braking", "--repeats", "1", "-o", full])
    assert result.exit_code == 2 and f"{full}: {os.strerror(28)}" in result.output
    assert stat.S_ISCHR(os.stat(full).st_mode)
