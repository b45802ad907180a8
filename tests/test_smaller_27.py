"""Issue 27's smaller items and its code-review findings, and item 6 of issue 24.

References are named per test: the verdicts of the stability pipeline (flutter against
divergence, decided from the eigenvalues' imaginary parts), LAPACK's QZ on a companion pencil
built here from the raw NLEVP arrays (scipy.linalg.eig), mpmath's polynomial roots at 50
digits, threadpoolctl's report of the BLAS thread count, and tracemalloc's peak.
"""

import numpy as np
import pytest

from squealkit.data import nlevp_path
from squealkit.models import get_preset, load_fe_model
from squealkit.stability import fe_stability_map, lock_in, stability_map
from squealkit.stability._solve import VERDICTS

FLUTTER = VERDICTS.index("flutter")

# -- 1. lock-in is mode coupling: flagged at flutter points, never at divergence ------------------


@pytest.fixture(scope="module")
def nlevp():
    return load_fe_model(nlevp_path())


def test_lock_in_on_the_nlevp_map_is_its_flutter_region(nlevp):
    # disk_brake100 over mu: stable, then a real root crosses zero (divergence, mu ~ 0.08), then
    # a complex pair with positive real part (flutter, mu > ~0.6): the verdicts are the reference
    ds = fe_stability_map(nlevp, rpm=[60.0, 240.0], mu=np.linspace(0.01, 1.5, 12), method="dense")
    verdict = ds.verdict.values
    assert {0, 1, 2} <= set(np.unique(verdict))  # the grid reaches all three
    np.testing.assert_array_equal(ds.lock_in.values, verdict == FLUTTER)


@pytest.mark.parametrize("damped", [False, True])
def test_lock_in_on_the_paper_model_is_its_flutter_region(damped):
    # Lv et al. 2013's 3-DOF model: every instability is mode coupling (paper §3); with its
    # dampers the coupled pair's frequencies approach (2371 and 2226 Hz) without meeting exactly
    ds = stability_map(get_preset("lv2013"), np.linspace(0, 1, 21), np.radians([-10.0, 0.0, 10.0]), damped=damped)
    verdict = ds.verdict.values
    assert (verdict == FLUTTER).any() and (verdict == 0).any()
    np.testing.assert_array_equal(ds.lock_in.values, verdict == FLUTTER)


def test_lock_in_function_ignores_real_roots_and_lone_negative_damping():
    # two real roots (omega 0), one growing: divergence, no coupling
    assert not lock_in(np.array([0.0, 0.0]), np.array([5.0, -3.0]))
    # a coupled pair: equal frequency, growth rates split (undamped mode coupling)
    assert lock_in(np.array([100.0, 100.0]), np.array([5.0, -5.0]))
    # damped coupling: the frequencies approach closer than the growth rates split
    assert lock_in(np.array([100.0, 97.0]), np.array([2.0, -8.0]))
    # one mode with negative damping, far in frequency from every other: not a lock-in
    assert not lock_in(np.array([100.0, 300.0]), np.array([1.0, -2.0]))
