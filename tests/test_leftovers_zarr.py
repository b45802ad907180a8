"""A streamed zarr result stops soon after a stop request (SIGTERM, Ctrl-C): its pieces are written in
chunks of bounded size and the write checks for the request before each chunk, so a run stops after
the chunks in flight, not after a whole piece (149 MB for a tile of a 3000 x 3000 stability map, 0.7-2.4 s),
and leaves no partial store. The mechanism is tested here; the latency is measured in the report (a
timed assertion does not belong in CI)."""

import numpy as np
import pytest
import xarray as xr
import zarr

from squealkit import io, scale

ROWS, COLS, PIECE, N_VARS = 32, 20000, 16, 12


def _piece(arg):
    """Rows ``a:b`` of a result of N_VARS variables (value: the row index plus the variable's number)."""
    a, b = arg
    rows = np.arange(a, b, dtype=float)[:, None] + np.zeros(COLS)
    return xr.Dataset({f"v{k}": (("row", "col"), rows + k) for k in range(N_VARS)},
                      coords={"row": np.arange(a, b), "col": np.arange(COLS)})


def _stream(store):
    template = scale.lazy_template(_piece((0, 1)), "row", np.arange(ROWS), PIECE)
    pieces = [(_piece, (a, a + PIECE), a, a + PIECE) for a in range(0, ROWS, PIECE)]
    return scale.stream_to_zarr(store, template, "row", pieces)


def test_a_streamed_store_is_chunked_in_bounded_pieces(tmp_path):
    # a piece is 16 rows x 20000 x 8 B = 2.56 MB per variable; each chunk holds at most ZARR_CHUNK_BYTES,
    # its rows those of one piece (pieces written at once by different workers never share a chunk)
    monkey_bound = 1 << 20
    old, scale.ZARR_CHUNK_BYTES = scale.ZARR_CHUNK_BYTES, monkey_bound
    try:
        ds = _stream(tmp_path / "s.zarr")
    finally:
        scale.ZARR_CHUNK_BYTES = old
    arr = zarr.open_array(tmp_path / "s.zarr" / "v3", mode="r")
    assert arr.chunks[0] == PIECE
    assert arr.chunks[1] < COLS and np.prod(arr.chunks) * 8 <= monkey_bound
    # and the values are the pieces' own (the reference: the pieces computed in memory)
    ref = xr.concat([_piece((a, a + PIECE)) for a in range(0, ROWS, PIECE)], "row")
    xr.testing.assert_equal(ds.compute(), ref)


def test_a_stop_request_ends_the_write_after_the_chunks_in_flight(tmp_path, monkeypatch):
    # the request arrives while the first piece's first chunk is written (as a signal handler records it
    # during a deferred write); before, the whole piece was written first (N_VARS chunks and more)
    written = []
    set_chunk = zarr.storage.LocalStore.set

    async def counting_set(self, key, value):
        if key.startswith("v") and "/c/" in key:   # a chunk of a data variable (not metadata, not coordinates)
            written.append(key)
            if len(written) == 1:
                io.note_interrupt()
        return await set_chunk(self, key, value)

    monkeypatch.setattr(zarr.storage.LocalStore, "set", counting_set)
    concurrency = int(zarr.config.get("async.concurrency"))
    try:
        with pytest.raises(KeyboardInterrupt):
            _stream(tmp_path / "s.zarr")
    finally:
        io.clear_interrupt()
    # the chunks already under way when the request came, at most zarr's concurrency, and no more
    assert 1 <= len(written) <= concurrency < N_VARS * ROWS // PIECE, written
    assert list(tmp_path.iterdir()) == []   # no partial store, no staging folder


def test_compiled_work_between_two_chances_to_stop_is_bounded():
    # a Python signal handler runs only between compiled calls: a map's kernels are called on blocks of at
    # most 2**16 points (whole rows), as its progress reports show (they come between the calls)
    from squealkit.models import get_preset
    from squealkit.stability import eigenvalues

    seen = []
    mu = np.linspace(0.0, 0.8, 120)[:, None]
    tan_theta = np.tan(np.radians(np.linspace(-8.0, 8.0, 1500)))[None, :]   # 180 000 points
    eigenvalues(get_preset("lv2013"), mu, tan_theta=tan_theta, progress=lambda done, total: seen.append(done))
    steps = np.diff([0, *seen])
    assert seen[-1] == mu.size * tan_theta.size and steps.max() <= 1 << 16, steps   # was one block of 2**18


@pytest.mark.slow
def test_sigterm_during_a_streamed_map_skips_the_final_collection_and_leaves_nothing(tmp_path):
    # the staged store is removed, then the process exits without the interpreter's last collection of
    # every object (1-2 s of a SIGTERM's latency on a loaded machine): they are frozen out of it (gc.freeze)
    import os
    import signal
    import subprocess
    import sys
    import time

    code = ("import atexit, gc, sys; atexit.register(lambda: print('frozen', gc.get_freeze_count(), file=sys.stderr)); "
            "from squealkit.cli.main import main; main()")
    p = subprocess.Popen([sys.executable, "-c", code, "stability", "--mu", "0:0.8:700", "--theta", "-8:8:3000",
                          "--out", "map.zarr"], stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.monotonic() + 300   # a loaded machine starts slowly
    while not any(n.startswith(".map.zarr") for n in os.listdir(tmp_path)):
        if p.poll() is not None or time.monotonic() > deadline:
            p.kill()
            pytest.fail(f"the staged store never appeared: {p.communicate()[1]}")
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    err = p.communicate(timeout=120)[1]
    assert p.returncode == 143 and "terminated" in err and "Traceback" not in err, err
    frozen = int(err.split("frozen")[-1].split()[0])
    assert frozen > 10_000, err   # the run's objects (numba, xarray, dask), left to the operating system
    assert os.listdir(tmp_path) == []
