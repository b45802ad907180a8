"""measurement/ laid out by concept (issue 28): the analysis is unchanged bit for bit, the figures
draw what the analysis returns and compute nothing, the old module paths keep working.

The golden values in tests/golden_measurement/ were written by its make_golden.py on the code
before the refactor (commit "tests: golden measurement outputs"): they are the reference.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

GOLDEN = Path(__file__).parent / "golden_measurement"
sys.path.insert(0, str(GOLDEN))

from _cases import analysis_arrays, cases, digest, figure_arrays  # noqa: E402


@pytest.fixture(scope="module")
def golden_cases():
    return cases()


def test_analysis_bit_identical_to_golden(golden_cases):
    # reference: analysis.npz, written by make_golden.py before measurement/ was split
    ref = np.load(GOLDEN / "analysis.npz")
    got = {}
    for name, (_rec, res, _kw) in golden_cases.items():
        got.update({f"{name}/{k}": v for k, v in analysis_arrays(res).items()})
    assert sorted(got) == sorted(ref.files)
    for k in ref.files:
        np.testing.assert_array_equal(got[k], ref[k], err_msg=k, strict=True)


def test_figures_draw_bit_identical_data(golden_cases):
    # reference: figures.json, digests of every line, mesh and scatter of the report's figures
    # as the plotting module drew them before it stopped computing (make_golden.py)
    ref = json.loads((GOLDEN / "figures.json").read_text())
    got = {}
    for name, (rec, res, kw) in golden_cases.items():
        got.update({f"{name}/{k}": digest(v) for k, v in figure_arrays(rec, res, kw).items()})
    assert sorted(got) == sorted(ref)
    assert [k for k in ref if got[k] != ref[k]] == []
