"""Stability of many models at once (squealkit.stability.ensemble) against the one-model engine."""

import numpy as np
import pytest
from scipy.linalg import block_diag

from squealkit import InputError
from squealkit.models import Hoffmann2002, MatrixModel, get_preset
from squealkit.stability import (
    ONSET_STATUS,
    ModelEnsemble,
    critical_friction,
    eigenvalues,
    ensemble_onset,
    ensemble_unstable,
    unstable_threshold,
)

MU = np.linspace(0.0, 0.8, 41)


def _lv_models(n=6, damped=False):
    base = get_preset("lv2013")
    rng = np.random.default_rng(3)
    return [base.replace(k3=base.k3 * (1 + 0.03 * z), k1=base.k1 * (1 + 0.02 * w))
            for z, w in rng.standard_normal((n, 2))]


@pytest.mark.parametrize("damped", [False, True])
def test_unstable_flags_equal_the_one_model_engine(damped):
    models = _lv_models(damped=damped)
    got = ensemble_unstable(ModelEnsemble.from_models(models, damped=damped), MU)
    for m, row in zip(models, got, strict=True):
        lam = eigenvalues(m, MU, damped=damped)
        expected = np.any(lam.real > unstable_threshold(lam)[:, None], axis=-1)
        np.testing.assert_array_equal(row, expected)


def test_onset_equals_critical_friction_and_hoffmann_closed_form():
    models = _lv_models()
    ens = ModelEnsemble.from_models(models)
    exact, status = ensemble_onset(ens, np.linspace(0.0, 2.0, 41), rtol=0.0)
    assert (status == 0).all()
    for m, x in zip(models, exact, strict=True):
        assert x == pytest.approx(critical_friction(m).mu_critical, abs=1e-9)
    # by default located to 1e-6 (of max(1, mu)) where rounding blurs the boundary (the lock-in)
    fast, _ = ensemble_onset(ens, np.linspace(0.0, 2.0, 41))
    np.testing.assert_allclose(fast, exact, rtol=0, atol=1e-6)
    # Hoffmann et al. (2002): mu_crit = ((a - d)^2 + 4 b^2) / (4 b k3), closed form
    hoff = ModelEnsemble.from_models(
        [Hoffmann2002(k3=k, k1=k1) for k, k1 in [(6e5, 1e6), (8e5, 1.1e6), (1e6, 0.9e6)]])
    closed = [Hoffmann2002(k3=k, k1=k1).mu_critical_closed_form() for k, k1 in [(6e5, 1e6), (8e5, 1.1e6), (1e6, 0.9e6)]]
    np.testing.assert_allclose(ensemble_onset(hoff, np.linspace(0.0, 1.0, 11), rtol=0.0)[0], closed, atol=1e-9)
    np.testing.assert_allclose(ensemble_onset(hoff, np.linspace(0.0, 1.0, 11))[0], closed, rtol=0, atol=1e-6)


def test_each_model_independent_of_the_rest_of_the_stack():
    models = _lv_models(8)
    whole = ModelEnsemble.from_models(models)
    u_all = ensemble_unstable(whole, MU)
    mu_all, st_all = ensemble_onset(whole, MU)
    for idx in ([0], [3, 1], [7, 2, 5]):
        sub = ModelEnsemble.from_models([models[i] for i in idx])
        np.testing.assert_array_equal(ensemble_unstable(sub, MU), u_all[idx])
        mu_s, st_s = ensemble_onset(sub, MU)
        np.testing.assert_array_equal(mu_s, mu_all[idx])
        np.testing.assert_array_equal(st_s, st_all[idx])


def test_status_and_censoring_outside_the_range():
    # the paper's rig loses stability at mu = 0.4448 (theta = 0; see test_stability):
    # outside the grid the onset is censored (NaN), never clipped to the range's end
    ens = ModelEnsemble.from_models([get_preset("lv2013")])
    mu_c, st = ensemble_onset(ens, np.linspace(0.5, 0.8, 4))
    assert [ONSET_STATUS[s] for s in st] == ["unstable_at_start"] and np.isnan(mu_c[0])
    mu_c, st = ensemble_onset(ens, np.linspace(0.0, 0.3, 4))
    assert [ONSET_STATUS[s] for s in st] == ["stable_in_range"] and np.isnan(mu_c[0])
    # run-out slope acts as friction (eq. 6): onset at mu_e = mu + tan(theta) ~ 0.4448
    mu_c, st = ensemble_onset(ens, MU, tan_theta=0.1)
    assert st.tolist() == [0] and mu_c[0] + 0.1 == pytest.approx(0.4448, abs=2e-3)


def test_large_models_use_lapack_and_agree():
    # a 5-DOF matrix model: Hoffmann's 2-DOF block plus three uncoupled oscillators
    h = Hoffmann2002()
    K0, Kn, Kf = h.stiffness_parts()
    pad = np.diag([2e6, 3e6, 5e6])
    m = MatrixModel(M=np.eye(5), K0=block_diag(K0, pad), Kn=block_diag(Kn, 0 * pad), Kf=block_diag(Kf, 0 * pad))
    mu_c, st = ensemble_onset(ModelEnsemble.from_models([m]), np.linspace(0, 0.5, 11))
    assert st[0] == 0 and mu_c[0] == pytest.approx(h.mu_critical_closed_form(), abs=1e-9)


def test_bad_input():
    ens = ModelEnsemble.from_models([Hoffmann2002()])
    with pytest.raises(InputError, match="strictly increasing"):
        ensemble_unstable(ens, [0.3, 0.2])
    with pytest.raises(InputError, match="same number of DOFs"):
        ModelEnsemble.from_models([Hoffmann2002(), get_preset("lv2013")])
    with pytest.raises(InputError, match="at least one model"):
        ModelEnsemble.from_models([])


def test_onsets_identical_when_the_search_runs_in_batches_of_rows(monkeypatch):
    # many rows are searched in batches (bounded memory); each row's result is unchanged
    from squealkit.stability import _windows

    ens = ModelEnsemble.from_models([Hoffmann2002(k3=k) for k in np.linspace(6e5, 1.2e6, 40)])
    whole = ensemble_onset(ens, np.linspace(0.0, 1.0, 51))
    monkeypatch.setattr(_windows, "_BATCH_POINTS", 51 * 7)
    batched = ensemble_onset(ens, np.linspace(0.0, 1.0, 51))
    np.testing.assert_array_equal(batched[0], whole[0])
    np.testing.assert_array_equal(batched[1], whole[1])
