"""Writes never replace what they should write into: a device file is written through, a FIFO
with a reader too, a FIFO without one, a symbolic link or a socket is refused with one line naming it."""

from __future__ import annotations

import errno
import os
import socket
import stat
import threading
import time

import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import check_writable, write_text_atomic


def _device(path, minor: int):
    """A character device node like /dev/null (minor 3) or /dev/full (minor 7), made in a test folder (root)."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
    except PermissionError:
        pytest.skip("making a device node needs root")
    return path


def test_a_device_is_written_through_and_never_replaced(tmp_path) -> None:
    null = _device(tmp_path / "null", 3)
    assert write_text_atomic(null, '{"rows": []}\n') == null
    assert stat.S_ISCHR(os.lstat(null).st_mode)  # still the device, not a JSON file in its place
    full = _device(tmp_path / "full", 7)  # what `eval --json /dev/full` meets
    with pytest.raises(OSError) as caught:
        write_text_atomic(full, "x" * 10)
    assert caught.value.errno == errno.ENOSPC
    assert stat.S_ISCHR(os.lstat(full).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full", "null"]  # no temporary file left beside them
    assert check_writable(null) == null


def test_a_symbolic_link_is_refused_and_left_as_it_is(tmp_path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    link = tmp_path / "out.json"
    link.symlink_to(victim)
    for write in (lambda: write_text_atomic(link, "x"), lambda: check_writable(link)):
        with pytest.raises(InputError, match=r"out\.json: is a symbolic link; platypose does not replace it"):
            write()
    assert link.is_symlink() and victim.read_text() == "keep"


def test_a_fifo_is_written_through_to_its_reader_and_refused_without_one(tmp_path) -> None:
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"pipe\.json: a FIFO \(named pipe\) that no one reads"):
        write_text_atomic(fifo, "lost")
    received, opened = [], threading.Event()

    def read_all() -> None:  # opens its end before the write (no probe, whose close would end the read early)
        fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        opened.set()
        data, deadline = b"", time.monotonic() + 10
        try:
            while time.monotonic() < deadline:
                try:
                    chunk = os.read(fd, 4096)
                except BlockingIOError:  # a writer is connected, nothing to read yet
                    chunk = None
                if chunk:
                    data += chunk
                elif chunk == b"" and data:  # the writer closed after writing
                    break
                else:
                    time.sleep(0.005)
        finally:
            os.close(fd)
        received.append(data.decode())

    reader = threading.Thread(target=read_all)
    reader.start()
    try:
        assert opened.wait(10)
        write_text_atomic(fifo, "through")
    finally:
        reader.join(15)
    assert received == ["through"] and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_socket_is_refused(tmp_path) -> None:
    path = tmp_path / "s.json"
    server = socket.socket(socket.AF_UNIX)
    try:
        server.bind(str(path))
        with pytest.raises(InputError, match=r"s\.json: is a socket; platypose does not replace it"):
            write_text_atomic(path, "x")
        assert stat.S_ISSOCK(os.lstat(path).st_mode)
    finally:
        server.close()


def test_a_lift_does_not_move_its_files_over_a_link_in_its_folder(tmp_path, monkeypatch) -> None:
    import platypose.exporters as exporters
    from platypose.cli.runs import outputs
    from platypose.lifting.job_log import JobLog

    staging, folder = tmp_path / "staging", tmp_path / "out/a"
    staging.mkdir()
    folder.mkdir(parents=True)
    victim = tmp_path / "victim.csv"
    victim.write_text("keep")
    (folder / "a.csv").symlink_to(victim)
    (staging / "a.csv").write_text("new")
    monkeypatch.setattr(exporters, "export", lambda *args, **kwargs: [staging / "a.csv"])
    with pytest.raises(InputError, match=r"a\.csv: is a symbolic link"):
        outputs.export_atomically(None, {}, staging, folder, "a", ("csv",), JobLog())
    assert (folder / "a.csv").is_symlink() and victim.read_text() == "keep"
