"""Property test for issue 30 (kept apart from the fast known-answer tests in test_edges.py): every
stability window of random 3-DOF models agrees with a dense LAPACK grid."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from test_edges import _check_windows_against_grid, _random_3dof


@settings(max_examples=10, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1))
def test_windows_agree_with_a_dense_lapack_grid(seed):
    # every clearly stable point of a 5e-4 grid (LAPACK) lies outside every reported window, and every
    # clearly unstable one inside
    _check_windows_against_grid(_random_3dof(seed), grid_n=4001)
