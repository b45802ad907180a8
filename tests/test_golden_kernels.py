"""The compiled kernels reproduce their golden cases bit for bit (issue #28: refactors change no number).

Reference: ``tests/golden/*.npz``, written by ``tests/golden/make_golden_kernels.py`` from the code as it was
before the kernels moved to :mod:`squealkit.solvers` (commit "tests: golden cases of the compiled
kernels"). Every case is recomputed here with the same settings and compared with ``np.array_equal``
(NaN equal to NaN): not a tolerance, the same bits.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

GOLDEN = Path(__file__).parent / "golden"


def _load_maker():
    spec = importlib.util.spec_from_file_location("make_golden_kernels", GOLDEN / "make_golden_kernels.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def computed() -> dict[str, dict[str, np.ndarray]]:
    return _load_maker().cases()


def _names() -> list[str]:
    return sorted(p.stem for p in GOLDEN.glob("*.npz"))


def test_every_golden_case_is_computed(computed):
    assert len(_names()) >= 13
    assert sorted(computed) == _names()


@pytest.mark.parametrize("name", _names())
def test_golden_case_is_bit_identical(computed, name):
    want = np.load(GOLDEN / f"{name}.npz")
    got = computed[name]
    assert sorted(got) == sorted(want.files)
    for key in want.files:
        a, b = np.asarray(got[key]), want[key]
        assert a.shape == b.shape, key
        assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), (
            f"{name}/{key}: max |difference| {np.nanmax(np.abs(a - b)) if a.size else 0:.3e}")


def test_golden_files_stay_small():
    assert sum(p.stat().st_size for p in GOLDEN.glob("*.npz")) < 2e6
