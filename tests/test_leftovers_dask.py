"""squealkit's local Dask clusters bind no dashboard unless asked: two in one process (as under
pytest-xdist, or beside a user's own cluster on 8787) start without "Port 8787 is already in use"."""

import contextlib
import socket
import warnings

import pytest

pytest.importorskip("distributed")


@pytest.fixture
def port_8787_taken():
    """Port 8787 held as another cluster's dashboard would hold it (or already taken by one)."""
    s = socket.socket()
    try:
        s.bind(("", 8787))
        s.listen(1)
    except OSError:
        pass  # already in use: the case itself
    try:
        yield
    finally:
        s.close()


def _http_get(port, path):
    """(status, body) of a GET of ``path`` from this machine's port ``port`` (loopback only)."""
    import urllib.error
    import urllib.request

    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=30) as r:
            return r.status, r.read().decode(errors="replace")
    except urllib.error.HTTPError as e:
        return e.code, ""


def _no_dashboard(port):
    """No dashboard at /status: nothing (404), or distributed's placeholder page that says bokeh is missing.

    The placeholder is not a dashboard: distributed appends its route to the routes list of the process's
    configuration once any cluster in the process started with a dashboard and no bokeh (seen under
    pytest-xdist, where another test's cluster ran first in the same worker), and later schedulers serve it."""
    status, body = _http_get(port, "/status")
    return status == 404 or (status == 200 and "for the dashboard" in body and "bokeh" in body)


def test_two_local_clusters_start_without_a_dashboard_port_warning(port_8787_taken):
    from squealkit.scale import cluster_client

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with contextlib.ExitStack() as stack:
            clients = [stack.enter_context(cluster_client("local", n_workers=1)) for _ in range(2)]
            # no dashboard (its /status page), and the scheduler's HTTP endpoints (/health) on a free port
            for client in clients:
                port = client.cluster.scheduler.http_server.port
                assert port != 8787
                assert _http_get(port, "/health")[0] == 200
                assert _no_dashboard(port)   # was the dashboard, on 8787 or the next free port
            assert clients[0].submit(sum, [1, 2]).result() == 3
    said = [str(w.message) for w in seen if "already in use" in str(w.message)]
    assert not said, said   # was "Port 8787 is already in use. Perhaps you already have a cluster running?"
