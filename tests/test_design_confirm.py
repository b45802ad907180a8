"""The countermeasure study's confirmation: eigenpair refinement per Newton point, the band solve kept as the check.

Two mode-coupling pairs (Hoffmann-type friction coupling, two frequencies) as a 4-DOF FE model. The confirmed
changes must be the same whichever way the changed models are solved, and each must be what LAPACK says:
references are the previous confirmation (a full solve of every changed model) and ``scipy.linalg.eig`` of the
companion pencil of the model at the confirmed value.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
import scipy.linalg as sla

from squealkit.design import COUNTERMEASURE_STATUS, countermeasures, design_parameters
from squealkit.fe import FEModel, rpm_to_disc_speed

K1 = np.diag([1.0, 1.2, 4.0, 4.5])
KR = np.zeros((4, 4))
KR[0, 1], KR[1, 0], KR[2, 3], KR[3, 2] = 1.0, -1.0, 1.5, -1.5
MODEL = FEModel.from_matrices(M=np.eye(4), K1=K1, KR=KR, D1=0.002 * np.eye(4))
TABLE = {"friction": "KR", "damping": "D1", "inner": {"part": "K1", "dofs": [0, 2]},
         "mass": {"mass": 0.0, "dofs": [1, 3], "step": 0.1}}


@pytest.fixture(scope="module")
def both():
    # the previous confirmation (a solve of every changed model) is still the fallback; its switch is the module's
    # flag (the module, not the function of the same name that squealkit.design exports)
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(sys.modules["squealkit.design.countermeasures"], "_REFINE", False)
        band = countermeasures(MODEL, TABLE, rpm=60.0, mu=0.25)
    finally:
        mp.undo()
    return band, countermeasures(MODEL, TABLE, rpm=60.0, mu=0.25)


def test_refined_confirmation_gives_the_full_solves_answer(both):
    band, refined = both
    assert band.sizes["mode"] == 2
    np.testing.assert_array_equal(refined.status.values, band.status.values)
    assert {"confirmed", "beyond_range"} <= set(refined.status.values.ravel())
    assert set(refined.status.values.ravel()) <= set(COUNTERMEASURE_STATUS)
    ok = refined.status.values == "confirmed"
    np.testing.assert_allclose(refined.confirmed_value.values[ok], band.confirmed_value.values[ok], rtol=1e-6)
    np.testing.assert_allclose(refined.confirmed_growth_rate.values[ok], band.confirmed_growth_rate.values[ok],
                               atol=1e-6)


def test_each_confirmed_value_is_stable_by_lapack(both):
    _, ds = both
    params = design_parameters(TABLE, MODEL)
    w = float(rpm_to_disc_speed(60.0))
    for i in range(ds.sizes["mode"]):
        for j, p in enumerate(params):
            if ds.status.values[i, j] != "confirmed":
                continue
            m = p.apply(MODEL, float(ds.confirmed_value.values[i, j]))
            M, C, K = (np.asarray(A.toarray()) for A in (m.mass_matrix(), m.damping_matrix(w, 0.25),
                                                          m.stiffness_matrix(w, 0.25)))
            n = M.shape[0]
            A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
            B = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), M]])
            lam = sla.eig(A, B, right=False)
            got = ds.confirmed_growth_rate.values[i, j] + 2j * np.pi * ds.confirmed_frequency_hz.values[i, j]
            k = np.argmin(np.abs(lam - got))
            assert abs(lam[k] - got) <= 1e-8 * abs(got)
            assert lam[k].real <= 1e-9 * abs(lam[k])  # stable (or neutral, the stability maps' rule)
