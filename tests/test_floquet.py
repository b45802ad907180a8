"""Floquet exponent of a periodic run-out.

References: issue 12 (the paper's Fig. 4 case, Lv, Zhang & Yu 2013 §4: mu = 0.4, c = 220 N s/m,
q0 = 0.08 mm, lambda = 1 mm, v = 0.02 m/s): Floquet exponent -0.3219 1/s against the period
average of the frozen-time sigma, -0.3241 1/s; the monodromy matrix checked against SciPy's
DOP853 (rtol 1e-11) on the first-order system built here; on a flat disc (q0 = 0) the exponent is
the largest eigenvalue's real part exactly.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from squealkit.models import get_preset
from squealkit.stability import eigenvalues
from squealkit.transient import SineRunOut
from squealkit.transient.floquet import floquet, floquet_map

LV = get_preset("lv2013")


def test_paper_case_against_frozen_time_average():
    r = floquet(LV, mu=0.4, amplitude=0.08e-3, wavelength=1e-3, speed=0.02)
    assert r.floquet_exponent == pytest.approx(-0.3219, abs=2e-4)
    assert r.frozen_mean == pytest.approx(-0.3241, abs=2e-4)
    assert abs(r.relative_difference) < 0.01


def test_monodromy_against_dop853():
    # a shorter period keeps the reference quick: lambda = 1 mm at 0.2 m/s (T = 5 ms)
    mu, q0, lam, v = 0.45, 0.05e-3, 1e-3, 0.2
    profile = SineRunOut(q0, lam)
    Minv, C = np.linalg.inv(LV.mass_matrix()), LV.damping_matrix()

    def rhs(t, y):
        K = LV.stiffness_matrix(mu, profile.evaluate(np.array([v * t]))[1][0])
        A = np.block([[np.zeros((3, 3)), np.eye(3)], [-Minv @ K, -Minv @ C]])
        return (A @ y.reshape(6, 6)).ravel()

    T = lam / v
    ref = solve_ivp(rhs, (0, T), np.eye(6).ravel(), method="DOP853", rtol=1e-11, atol=1e-13)
    rho_ref = np.log(np.abs(np.linalg.eigvals(ref.y[:, -1].reshape(6, 6))).max()) / T
    r = floquet(LV, mu=mu, amplitude=q0, wavelength=lam, speed=v)
    assert r.floquet_exponent == pytest.approx(rho_ref, abs=1e-3 * abs(rho_ref) + 1e-6)


def test_flat_disc_is_the_eigenvalue():
    r = floquet(LV, mu=0.5, amplitude=0.0, wavelength=1e-3, speed=0.02)
    sigma = float(eigenvalues(LV, 0.5, tan_theta=0.0, damped=True).real.max())
    assert r.floquet_exponent == pytest.approx(sigma, rel=1e-6)
    assert r.frozen_mean == pytest.approx(sigma, rel=1e-12)


def test_map_and_cli(run, tmp_path):
    ds = floquet_map(LV, mu=[0.38, 0.42], amplitude=[0.0, 4e-5], wavelength=1e-3, speed=0.02, steps_per_period=4000)
    assert ds.floquet_exponent.shape == (2, 2) and ds.attrs["steps_per_period"] == 4000
    r = run("floquet", "--mu", "0.4", "--sro-amplitude", "8e-5", "--sro-wavelength", "1e-3", "--speed", "0.02",
            "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert out["floquet_exponent"] == pytest.approx(-0.3219, abs=2e-4)
    png = tmp_path / "map.png"
    r = run("floquet", "--mu", "0.38:0.42:2", "--sro-amplitude", "0:4e-5:2", "--plot", str(png))
    assert r.exit_code == 0, r.output
    assert png.stat().st_size > 1000
    r = run("floquet", "--speed", "-1")
    assert r.exit_code == 2
