"""Monte Carlo squeal propensity (squealkit.uncertainty) against closed forms, and its CLI."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy import stats

from squealkit import InputError
from squealkit.io import load_dataset, save_dataset
from squealkit.models import Hoffmann2002, PinOnDisc3DOF, get_preset, load_model
from squealkit.stability import critical_friction, critical_friction_sensitivity
from squealkit.uncertainty import (
    UncertainParameter,
    load_uncertain,
    parse_uncertain,
    propensity_summary,
    sample_parameters,
    squeal_propensity,
)

EXAMPLE = Path(__file__).parents[1] / "examples" / "uncertain_rig.toml"
HOFF_MU = np.linspace(0.18, 0.34, 17)
# k3 scatters (drives the flutter threshold); the mass m does not enter the undamped
# threshold at all (Hoffmann et al. 2002: it scales every eigenvalue alike)
HOFF_UNC = {"k3": {"dist": "normal", "mean": 8e5, "std": 8e4}, "m": {"dist": "uniform", "lower": 0.5, "upper": 2.0}}


def hoffmann_probability(mu, mean, std):
    """Exact P(mu_crit(k3) <= mu) for k3 ~ normal(mean, std) in Hoffmann2002's default model.

    From Hoffmann et al. (2002) (``Hoffmann2002.mu_critical_closed_form``):
    mu_crit = ((a - d0 - k3)^2 + 4 b^2) / (4 b k3), with a = K11, b = K21, d0 = K22 of the
    supports. mu_crit <= mu is a quadratic inequality in k3, so the probability is the
    normal distribution's mass between its two roots.
    """
    K0 = Hoffmann2002()._support()
    a, b, d0 = K0[0, 0], K0[1, 0], K0[1, 1]
    c = a - d0
    p = 2 * c + 4 * b * mu
    disc = p * p - 4 * (c * c + 4 * b * b)
    root = np.sqrt(np.maximum(disc, 0.0))
    dist = stats.norm(mean, std)
    return np.where(disc > 0, dist.cdf((p + root) / 2) - dist.cdf((p - root) / 2), 0.0)


@pytest.fixture(scope="module")
def hoff():
    return squeal_propensity(Hoffmann2002(), HOFF_UNC, HOFF_MU, samples=2048, seed=7)


# -- the probability against closed forms --------------------------------------------------


def test_probability_matches_hoffmann_closed_form(hoff):
    truth = hoffmann_probability(HOFF_MU, 8e5, 8e4)
    p = hoff.probability_unstable.values
    n = hoff.attrs["samples"]
    # binomial sampling error: within 4 standard deviations everywhere
    assert np.all(np.abs(p - truth) <= 4 * np.sqrt(truth * (1 - truth) / n) + 1.5 / n)
    # the 95% Clopper-Pearson band covers the truth (at >= 95% of points per point; allow chance)
    covered = (hoff.ci_lower.values <= truth) & (truth <= hoff.ci_upper.values)
    assert covered.mean() >= 0.9
    assert np.all(hoff.ci_lower.values <= p) and np.all(p <= hoff.ci_upper.values)
    assert hoff.probability_unstable.values[0] == 0.0 and truth[0] < 1e-3


def test_sample_critical_friction_is_hoffmanns_closed_form(hoff):
    k3 = hoff.parameter_value.sel(parameter="k3").values
    onset = hoff.onset_status.values == 0
    expected = [Hoffmann2002(k3=k).mu_critical_closed_form() for k in k3[onset][:50]]
    # samples' onsets are located to 1e-6 (of max(1, mu)) (ensemble_onset's default rtol)
    np.testing.assert_allclose(hoff.mu_critical.values[onset][:50], expected, rtol=0, atol=1e-6)
    # censored (NaN, with a warning) where the onset lies beyond the range, never clipped
    assert np.all(np.isnan(hoff.mu_critical.values[hoff.onset_status.values == 2]))


def test_binomial_band_is_scipys_clopper_pearson(hoff):
    k, n = int(hoff.unstable_count[8]), hoff.attrs["samples"]
    ci = stats.binomtest(k, n).proportion_ci(0.95, method="exact")
    assert (float(hoff.ci_lower[8]), float(hoff.ci_upper[8])) == (ci.low, ci.high)


# -- the sensitivity ------------------------------------------------------------------------


def test_sobol_irrelevant_parameter_is_zero_and_driver_is_one(hoff):
    s1, st = hoff.sobol_first_order, hoff.sobol_total
    # only k3 moves mu_crit: its indices are 1, the mass's 0 (rounding of the bisection only)
    assert abs(float(s1.sel(parameter="m"))) < 1e-6 and abs(float(st.sel(parameter="m"))) < 1e-6
    assert float(s1.sel(parameter="k3")) == pytest.approx(1.0, abs=0.1)
    assert float(st.sel(parameter="k3")) == pytest.approx(1.0, abs=0.1)
    assert float(hoff.sobol_total_ci_lower.sel(parameter="k3")) <= 1.0 <= float(
        hoff.sobol_total_ci_upper.sel(parameter="k3"))
    # mu_crit falls as k3 grows over most of this range (d mu_crit / d k3 = -b / k3^2 at a = d)
    assert float(hoff.spearman.sel(parameter="k3")) < -0.5


def test_sobol_matches_linearised_variance_shares():
    # Small scatter: mu_crit ~ linear in the parameters, so the first-order and total
    # indices both approach (dmu/dp_i sigma_i)^2 / sum_j (dmu/dp_j sigma_j)^2, with the
    # derivatives from critical_friction_sensitivity (central differences).
    model = get_preset("lv2013")
    cv = {"k3": 0.005, "k1": 0.005, "kc": 0.01}
    unc = {k: {"dist": "normal", "mean": getattr(model, k), "std": c * getattr(model, k)} for k, c in cv.items()}
    rows = {r["parameter"]: r for r in critical_friction_sensitivity(model, parameters=list(cv))}
    var = np.array([(rows[k]["dmu_dp"] * cv[k] * getattr(model, k)) ** 2 for k in cv])
    shares = var / var.sum()
    ds = squeal_propensity(model, unc, np.linspace(0.3, 0.6, 16), samples=1024, seed=2)
    assert (ds.onset_status.values == 0).all()
    np.testing.assert_allclose(ds.sobol_first_order.values, shares, atol=0.08)
    np.testing.assert_allclose(ds.sobol_total.values, shares, atol=0.08)
    assert float(ds.mu_critical.std()) == pytest.approx(math.sqrt(var.sum()), rel=0.1)
    assert ds.attrs["nominal_mu_critical"] == pytest.approx(critical_friction(model).mu_critical, abs=1e-9)


# -- reproducibility and distribution ------------------------------------------------------


@pytest.mark.slow
def test_same_seed_same_result_whatever_the_batching(hoff):
    again = squeal_propensity(Hoffmann2002(), HOFF_UNC, HOFF_MU, samples=2048, seed=7, batch_size=333)
    xr.testing.assert_identical(again, hoff)
    other = squeal_propensity(Hoffmann2002(), HOFF_UNC, HOFF_MU, samples=2048, seed=8, sensitivity=False)
    assert not np.array_equal(other.parameter_value.values, hoff.parameter_value.values)
    assert "sobol_total" not in other and propensity_summary(other)["sensitivity"] is None


def test_dask_client_gives_identical_result(hoff):
    distributed = pytest.importorskip("distributed")
    seen = []
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        ds = squeal_propensity(Hoffmann2002(), HOFF_UNC, HOFF_MU, samples=2048, seed=7, batch_size=500,
                               client=client, progress=lambda done, total: seen.append((done, total)))
    xr.testing.assert_identical(ds, hoff)
    total = 2048 + 2 * 1024
    assert seen[-1] == (total, total) and len(seen) == math.ceil(total / 500)


@pytest.mark.parametrize(
    "spec, mean, std",
    [
        ({"dist": "normal", "mean": 3.0, "std": 0.5}, 3.0, 0.5),
        ({"dist": "uniform", "lower": 1.0, "upper": 4.0}, 2.5, 3.0 / math.sqrt(12)),
        # lognormal by the variable's own mean and std
        ({"dist": "lognormal", "mean": 2.0, "std": 0.6}, 2.0, 0.6),
        # lognormal by median and sigma of ln x: mean = median e^(s^2/2), var = mean^2 (e^(s^2) - 1)
        ({"dist": "lognormal", "median": 2.0, "sigma": 0.3}, 2.0 * math.exp(0.045),
         2.0 * math.exp(0.045) * math.sqrt(math.expm1(0.09))),
    ],
)
def test_sample_moments(spec, mean, std):
    spec = dict(spec)
    p = UncertainParameter("k1", spec.pop("dist"), spec)
    assert float(p.distribution.mean()) == pytest.approx(mean, rel=1e-12)
    assert float(p.distribution.std()) == pytest.approx(std, rel=1e-12)
    x = sample_parameters([p], 100_000, np.random.default_rng(0))[:, 0]
    assert x.mean() == pytest.approx(mean, abs=5 * std / math.sqrt(x.size))
    assert x.std() == pytest.approx(std, rel=0.02)
    assert stats.kstest(x, p.distribution.cdf).pvalue > 1e-3


def test_degrees_are_sampled_in_degrees():
    model = get_preset("lv2013")
    unc = {"alpha_deg": {"dist": "uniform", "lower": 1.0, "upper": 3.0}}
    ds = squeal_propensity(model, unc, np.linspace(0.3, 0.6, 7), samples=8, seed=1, sensitivity=False)
    assert ds.parameter_unit.values.tolist() == ["deg"]
    a = float(ds.parameter_value[0, 0])
    assert 1.0 <= a <= 3.0
    ref = critical_friction(model.replace(alpha_deg=a)).mu_critical
    assert float(ds.mu_critical[0]) == pytest.approx(ref, abs=1e-6)  # ensemble_onset's default rtol


def test_dataset_round_trips(tmp_path, hoff):
    for name in ("mc.nc", "mc.zarr"):
        save_dataset(hoff, tmp_path / name)
        back = load_dataset(tmp_path / name)
        xr.testing.assert_equal(back, hoff)
        assert back.attrs["seed"] == 7 and json.loads(back.attrs["uncertain"])[0]["name"] == "k3"


# -- input ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "table, message",
    [
        ({"k9": {"dist": "normal", "mean": 1, "std": 1}}, "Unknown uncertain parameter 'k9'"),
        ({"sliding": {"dist": "uniform", "lower": -1, "upper": 1}}, "'sliding' of model 'pin_on_disc' cannot be"),
        ({"k3": {"dist": "gamma", "mean": 1, "std": 1}}, "k3: unknown dist='gamma'"),
        ({"k3": {"mean": 1, "std": 1}}, "k3: missing dist"),
        ({"k3": {"dist": "normal", "mean": 1e9}}, "k3: a normal distribution takes mean+std, got mean"),
        ({"k3": {"dist": "normal", "mean": 1e9, "std": -1e7}}, "k3: std=-10000000.0 must be > 0"),
        ({"k3": {"dist": "normal", "mean": "a", "std": 1}}, "k3.mean='a' is not a number"),
        ({"kc": {"dist": "uniform", "lower": 5e7, "upper": 4e7}}, "kc: lower=50000000.0 must be < upper"),
        ({"kc": {"dist": "lognormal", "mean": -1, "std": 1}}, "kc: a lognormal mean=-1.0 must be > 0"),
        ({"kc": {"dist": "lognormal", "mean": 1, "sigma": 1}}, "kc: a lognormal distribution takes mean+std or"),
        ({"alpha": {"dist": "normal", "mean": 0.03, "std": 0.01},
          "alpha_deg": {"dist": "normal", "mean": 2, "std": 0.1}}, "alpha_deg: alpha is already uncertain"),
        ({"k1_deg": {"dist": "normal", "mean": 2, "std": 0.1}}, "Unknown uncertain parameter 'k1_deg'"),
        ({"k3": 9.452e8}, "k3: give a table like"),
        ({}, "[uncertain] table is empty"),
    ],
)
def test_bad_uncertain_table_names_the_parameter(table, message):
    with pytest.raises(InputError) as e:
        parse_uncertain(table, PinOnDisc3DOF)
    assert message in str(e.value)
    assert "\n" not in str(e.value)


def test_sampled_value_outside_the_allowed_range_is_an_error():
    unc = {"k3": {"dist": "normal", "mean": 8e5, "std": 4e5}}
    with pytest.raises(InputError, match=r"k3: \d+ of 512 sampled values are outside the allowed range \(> 0\)"):
        squeal_propensity(Hoffmann2002(), unc, HOFF_MU, samples=512)
    unc = {"alpha_deg": {"dist": "uniform", "lower": 80, "upper": 100}}
    with pytest.raises(InputError, match=r"alpha_deg: .*\(strictly between -90 and 90 deg\)"):
        squeal_propensity(get_preset("lv2013"), unc, HOFF_MU, samples=64)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"samples": 1}, "samples=1 must be an integer >= 2"),
        ({"samples": 2.5}, "samples=2.5 must be an integer"),
        ({"samples": 8, "confidence": 1.0}, "confidence=1.0 must lie strictly between 0 and 1"),
        ({"samples": 8, "seed": -1}, "seed=-1 must be an integer >= 0"),
        ({"samples": 8, "theta": 2.0}, "theta=2.0 rad"),
        ({"samples": 8, "batch_size": 0}, "batch_size=0"),
    ],
)
def test_bad_arguments(kwargs, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        squeal_propensity(Hoffmann2002(), HOFF_UNC, HOFF_MU, **kwargs)


def test_example_file_loads():
    model = load_model(EXAMPLE)
    unc = load_uncertain(EXAMPLE)
    assert model == get_preset("lv2013")
    assert [p.name for p in unc] == ["k3", "k1", "kc", "alpha_deg"]
    # the example entry: k3 = {dist = "normal", mean = 9.452e8, std = 4.7e7}
    assert unc[0] == UncertainParameter("k3", "normal", {"mean": 9.452e8, "std": 4.7e7})


def test_load_uncertain_errors_name_the_file(tmp_path):
    f = tmp_path / "rig.toml"
    f.write_text('preset = "lv2013"\n')
    with pytest.raises(InputError, match=r"rig.toml has no \[uncertain\] table"):
        load_uncertain(f)
    f.write_text('preset = "lv2013"\n[uncertain]\nk3 = {dist = "normal", mean = 9e8}\n')
    with pytest.raises(InputError, match=r"rig\.toml: Uncertain parameter k3: a normal distribution takes mean"):
        load_uncertain(f)


# -- plots and CLI ---------------------------------------------------------------------------


def test_plots(hoff):
    from squealkit.plotting.uncertainty import propensity_plot, sensitivity_plot, uncertainty_plot

    fig = propensity_plot(hoff)
    assert fig.axes[0].get_ylabel() == "probability of instability"
    assert len(sensitivity_plot(hoff).axes[0].patches) == 4
    assert len(uncertainty_plot(hoff).axes) == 2
    no_sens = hoff.drop_vars([v for v in hoff.data_vars if v.startswith(("sobol", "spearman"))])
    assert len(uncertainty_plot(no_sens).axes) == 1
    with pytest.raises(InputError, match="no Sobol' indices"):
        sensitivity_plot(no_sens)


@pytest.fixture()
def spread(tmp_path):
    f = tmp_path / "spread.toml"
    f.write_text('[uncertain]\nk3 = {dist = "normal", mean = 8e5, std = 8e4}\n'
                 'm = {dist = "uniform", lower = 0.5, upper = 2.0}\n')
    return f


def test_cli_json(run, spread, hoff):
    r = run("montecarlo", "--preset", "hoffmann2002", "--uncertain", str(spread), "--samples", "2048", "--seed", "7",
            "--mu", "0.18:0.34:17", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert len(out["mu"]) == len(out["probability_unstable"]) == len(out["ci_lower"]) == len(out["ci_upper"]) == 17
    # the CLI calls the library: the same numbers as the Python run with this seed
    assert out["probability_unstable"] == hoff.probability_unstable.values.tolist()
    assert out["samples"] == 2048 and out["seed"] == 7 and out["ci_method"] == "clopper-pearson"
    assert set(out["sensitivity"]) == {"k3", "m"}
    assert set(out["sensitivity"]["k3"]) >= {"first_order", "total", "first_order_ci", "total_ci", "spearman"}
    assert out["nominal_mu_critical"] == pytest.approx(Hoffmann2002().mu_critical_closed_form(), abs=1e-9)


def test_cli_text_and_files(run, tmp_path):
    nc, png = tmp_path / "mc.nc", tmp_path / "mc.png"
    r = run("montecarlo", "--config", str(EXAMPLE), "--samples", "64", "--mu", "0:1:41", "--out", str(nc),
            "--plot", str(png))
    assert r.exit_code == 0, r.output
    assert "P(unstable)" in r.stdout and "Sobol'" in r.stdout and "alpha_deg" in r.stdout
    assert "(21 of 41 mu points" in r.stdout
    assert load_dataset(nc).sizes["mu"] == 41
    assert png.read_bytes()[:4] == b"\x89PNG"
    r = run("montecarlo", "--config", str(EXAMPLE), "--samples", "16", "--mu", "0.3:0.6:4", "--no-sensitivity",
            "--theta", "2")
    assert r.exit_code == 0, r.output
    assert "Sobol'" not in r.stdout and "theta = 2 deg" in r.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["montecarlo"], "montecarlo needs an [uncertain] table"),
        (["montecarlo", "--config", "examples/myrig.toml"], "myrig.toml has no [uncertain] table"),
        (["montecarlo", "--config", str(EXAMPLE), "--mu", "0.5:0.2:4"], "strictly increasing"),
        (["montecarlo", "--config", str(EXAMPLE), "--samples", "1"], "samples=1 must be an integer >= 2"),
        (["montecarlo", "--config", str(EXAMPLE), "--theta", "95"], "between -90 and 90"),
        (["montecarlo", "--config", str(EXAMPLE), "--out", "x.csv"], "must end in .nc or .zarr"),
        (["montecarlo", "--config", str(EXAMPLE), "--set", "k9=1"], "Unknown parameter 'k9'"),
    ],
)
def test_cli_bad_input_is_one_line_exit_2(run, args, message, monkeypatch):
    monkeypatch.chdir(Path(__file__).parents[1])
    r = run(*args)
    assert r.exit_code == 2, r.output
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
