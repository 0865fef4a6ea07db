"""atomic_write: concurrent writers of one file leave one complete version; a failed write leaves the old one."""

import threading

import pytest

from loco_mujoco.atomic_write import atomic_write


def test_concurrent_writers_leave_one_complete_file_and_no_temporaries(tmp_path):
    path = tmp_path / "cache" / "data.bin"
    start = threading.Barrier(8)

    def write(i: int) -> None:
        start.wait()
        with atomic_write(path) as handle:
            for _ in range(200):  # many small writes, so unsynchronised writers would interleave
                handle.write(bytes([i]) * 512)

    threads = [threading.Thread(target=write, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    data = path.read_bytes()
    assert len(data) == 200 * 512
    assert len(set(data)) == 1  # one writer's bytes only
    assert [p.name for p in path.parent.iterdir()] == ["data.bin"]
    assert path.stat().st_mode & 0o777 == 0o644


def test_a_failed_write_keeps_the_old_file(tmp_path):
    path = tmp_path / "refs.json"
    path.write_text("old")
    with pytest.raises(RuntimeError, match="disk full"):
        with atomic_write(path, "w") as handle:
            handle.write("new, half")
            raise RuntimeError("disk full")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["refs.json"]


def test_only_whole_file_write_modes_are_accepted(tmp_path):
    with pytest.raises(ValueError, match="'w' or 'wb'.*'ab'"):
        with atomic_write(tmp_path / "x", "ab"):
            pass
