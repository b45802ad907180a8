"""Outputs are written completely or not at all."""

import pytest

from squealkit import InputError
from squealkit.io import atomic_path, write_text


def test_failed_write_keeps_the_old_file(tmp_path):
    target = tmp_path / "result.json"
    write_text(target, "good")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert target.read_text() == "good"
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]


def test_failed_directory_write_keeps_the_old_store(tmp_path):
    target = tmp_path / "store.zarr"
    with atomic_path(target, directory=True) as tmp:  # a store squealkit wrote (its manifest says so)
        tmp.mkdir()
        (tmp / "old").write_text("x")
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target, directory=True) as tmp:
            tmp.mkdir()
            raise KeyboardInterrupt
    assert (target / "old").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["store.zarr"]


def test_missing_output_folder_is_a_clear_error(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        write_text(tmp_path / "nope" / "a.txt", "x")
