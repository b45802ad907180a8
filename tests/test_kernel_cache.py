"""The limit cycles' RK4 monodromy kernel is kept in numba's on-disk cache from one process to the next."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

CALL = """
import json
import numpy as np
from squealkit.solvers import ode
phi = ode.monodromy_rk4(ode.sampled_rhs, np.zeros((3, 2, 2)), 1, 0.5, 2)
d = ode._sampled_monodromy
print(json.dumps({"hits": sum(d.stats.cache_hits.values()), "misses": sum(d.stats.cache_misses.values()),
                  "phi": phi.tolist()}))
"""


@pytest.mark.slow
def test_sampled_monodromy_is_loaded_from_the_cache_by_a_second_process(tmp_path):
    # reference: numba's dispatcher statistics; A = 0 gives Phi = I exactly (closed form)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "SQUEALKIT_THREADS": "1"}
    runs = [json.loads(subprocess.run([sys.executable, "-c", CALL], env=env, capture_output=True, text=True,
                                      check=True).stdout) for _ in range(2)]
    assert runs[0]["misses"] == 1 and runs[0]["hits"] == 0  # a cold cache: compiled, and saved
    assert runs[1]["hits"] == 1 and runs[1]["misses"] == 0  # the second process loads it
    assert runs[1]["phi"] == [[1.0, 0.0], [0.0, 1.0]]


LOOPS = """
import json
from squealkit.solvers.ode import adaptive, dp5, rk4
from squealkit.models import get_preset
from squealkit.transient import simulate
model = get_preset("lv2013")
simulate(model, mu=0.35, duration=0.002, method="dopri5")
simulate(model, mu=0.35, duration=0.002, method="rk4")
print(json.dumps({"hits": sum(dp5.integrate_adaptive.stats.cache_hits.values()),
                  "loops_compiled": len(dp5._dp5_run.signatures) + len(rk4._rk4_run.signatures)}))
"""


@pytest.mark.slow
def test_the_integrators_loops_come_with_their_cached_kernels():
    # the per-run loops (adaptive.run as _dp5_run, rk4._rk4_run) have no cache entry of their own
    # (tests/test_done_when_28.py: CALLEES_OF_CACHED_KERNELS): a process that loads the kernels from
    # the cache must not compile them. Reference: numba's dispatcher statistics and signatures; the
    # first process fills the project's cache if a test before has not
    env = {**os.environ, "SQUEALKIT_THREADS": "1"}
    runs = [json.loads(subprocess.run([sys.executable, "-c", LOOPS], env=env, capture_output=True, text=True,
                                      check=True).stdout) for _ in range(2)]
    assert runs[1]["hits"] >= 1 and runs[1]["loops_compiled"] == 0
