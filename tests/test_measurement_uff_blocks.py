"""UFF 58 recordings are read block by block (issue #14: "all streaming in blocks").

A UFF 58 function is one record per channel; pyuff parses a whole record at once (and reads the
whole file to find the records). The reader finds the records itself and reads each wanted
record block by block, ASCII (4E20.12 per line, as ``write_recording`` writes it) or binary
(58b, raw floats). The reference is pyuff's own reading of the same file, and the samples
written.
"""

import numpy as np
import pytest

from squealkit import InputError
from squealkit.measurement import open_recording, synthetic_recording
from squealkit.measurement.formats.writers import write_recording

pyuff = pytest.importorskip("pyuff")
NAMES = ["mic", "displacement", "tacho"]


@pytest.fixture(scope="module")
def rec():
    return synthetic_recording(duration=0.2, seed=1)  # 8000 samples of 3 channels


@pytest.fixture(scope="module")
def ascii_uff(rec, tmp_path_factory):
    return write_recording(rec, tmp_path_factory.mktemp("uff") / "rec.uff")


def _binary_copy(ascii_path, rec, path, *, cut=0):
    """The same records as binary 58b (little-endian doubles after the ASCII header lines)."""
    lines = ascii_path.read_bytes().splitlines(True)
    out, i, k = [], 0, 0
    while i < len(lines):
        if lines[i].rstrip() == b"    -1" and i + 1 < len(lines) and lines[i + 1].strip() == b"58":
            head = lines[i:i + 13]
            n_bytes = 8 * rec.sizes["time"]
            head[1] = b"    58b%6i%6i%12i%12i%6i%6i%12i%12i\n" % (1, 2, 11, n_bytes, 0, 0, 0, 0)
            data = rec[NAMES[k]].values.astype("<f8").tobytes()
            out += [*head, data[:len(data) - cut], b"\n    -1\n"]
            k += 1
            i += 13
            while lines[i].rstrip() != b"    -1":
                i += 1
        i += 1
    path.write_bytes(b"".join(out))
    return path


def _read_all(src, names, block):
    parts = {n: [] for n in names}
    for _, blk in src.iter_blocks(names, block=block):
        for n in names:
            parts[n].append(blk[n])
    return {n: np.concatenate(v) for n, v in parts.items()}


@pytest.mark.parametrize("block", [1000, 4097, 1 << 18])
def test_ascii_blocks_equal_pyuffs_whole_records_without_pyuff(ascii_uff, block, monkeypatch):
    src = open_recording(ascii_uff)
    uff = pyuff.UFF(str(ascii_uff))
    ref = {n: np.asarray(uff.read_sets(src._extra["sets"][n])["data"], dtype=float) for n in NAMES}

    def whole_record(*args, **kwargs):
        raise AssertionError("a block read parsed a whole record with pyuff")

    monkeypatch.setattr(pyuff.UFF, "read_sets", whole_record)
    got = _read_all(src, NAMES[:2], block)  # two of the three channels: only those are read
    for n in NAMES[:2]:
        assert np.array_equal(got[n], ref[n])


def test_binary_58b_blocks_equal_the_samples_written(ascii_uff, rec, tmp_path):
    src = open_recording(_binary_copy(ascii_uff, rec, tmp_path / "b.uff"))
    got = _read_all(src, NAMES, 3000)
    for n in NAMES:
        assert np.array_equal(got[n], rec[n].values)


def test_truncated_binary_record_is_one_clear_error(ascii_uff, rec, tmp_path):
    path = _binary_copy(ascii_uff, rec, tmp_path / "cut.uff", cut=800)  # 100 samples short
    src = open_recording(path)
    with pytest.raises(InputError, match="ends after 7900 of 8000 samples"):
        _read_all(src, ["mic"], 3000)
