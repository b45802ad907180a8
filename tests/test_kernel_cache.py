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
