"""``squealkit design --doe`` and ``--scatter``, driven in-process on a 2-DOF friction-coupled FE model.

Reference values: the Python API (:func:`squealkit.design.doe_sweep`, :func:`squealkit.design.robust_margins`) on
the same model with the same arguments; tests/test_design.py and tests/test_design_robust.py check those against
closed forms and central differences.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

MATS = {"M": np.eye(2), "K1": np.diag([1.0, 1.2]), "KR": np.array([[0.0, 1.0], [-1.0, 0.0]]), "D1": 0.001 * np.eye(2)}


def _chain() -> dict[str, np.ndarray]:
    """24 unit masses in a fixed-free spring chain (modes up to 8 kHz), a random skew friction coupling of 1 % of
    the spring (seed 0): one pair coalesces between friction scales 0.8 and 1 (the DOE below finds where)."""
    n, k = 24, (2 * np.pi * 4000) ** 2 / 4
    K1 = k * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    K1[-1, -1] = k
    A = np.random.default_rng(0).normal(size=(n, n))
    return {"M": np.eye(n), "K1": K1, "KR": 0.01 * k * (A - A.T), "D1": 5.0 * np.eye(n)}


def _write(folder, mats) -> object:
    for name, A in mats.items():
        scipy.io.mmwrite(folder / f"{name}.mtx", sp.coo_matrix(A))
    files = ", ".join(f'{n} = "{(folder / f"{n}.mtx").as_posix()}"' for n in mats)
    path = folder / "model.toml"
    path.write_text(f'model = "fe"\n[fe]\nfiles = {{{files}}}\n\n[design]\nfriction = "KR"\ndamping = "D1"\n')
    return path


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    return _write(tmp_path_factory.mktemp("coupled"), MATS)


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    return _write(tmp_path_factory.mktemp("chain"), _chain())


def _run(*args):
    from click.testing import CliRunner

    from squealkit.cli.main import cli

    return CliRunner().invoke(cli, ["design", *map(str, args)])


def test_scatter_gives_the_apis_robust_margins(config):
    from squealkit.design import robust_margins
    from squealkit.models import load_model

    # mu = 0.102: just above the pair's coalescence (onset 0.1 undamped), so 5 % friction scatter makes it squeal
    # in some samples, and the perturbation estimate says indeterminate (null) rather than a wrong number
    r = _run("--config", config, "--rpm", 60, "--mu", 0.102, "--scatter", "KR=0.05", "--scatter", "D1=0.3:lognormal",
             "--samples", 300, "--seed", 3, "--json")
    assert r.exit_code == 0, r.output
    got = json.loads(r.stdout)
    with pytest.warns(UserWarning):
        ref = robust_margins(load_model(config), rpm=60.0, mu=0.102, samples=300, seed=3,
                             scatter={"KR": {"dist": "normal", "cov": 0.05}, "D1": {"dist": "lognormal", "cov": 0.3}})
    assert [e["name"] for e in got["estimators"]] == ["montecarlo", "perturbation"]
    mc, pert = got["estimators"]
    assert mc["propensity"] == pytest.approx(float(ref.propensity[0]), rel=1e-12)
    assert 0.1 < mc["propensity"] < 0.9  # neither always nor never: a real check
    assert pert["propensity"] is None and {m["perturbation_status"] for m in got["modes"]} == {"indeterminate"}
    assert got["samples"] == 300 and got["seed"] == 3 and got["trusted"] == 1
    assert [m["frequency_hz"] for m in got["modes"]] == pytest.approx(ref.frequency_hz.values.tolist(), rel=1e-12)


def test_doe_gives_the_apis_sweep_and_its_pareto_points(chain, tmp_path):
    import xarray as xr

    from squealkit.design import doe_sweep, load_design
    from squealkit.models import load_model

    out = tmp_path / "doe"
    r = _run("--config", chain, "--rpm", 60, "--mu", 1.0, "--doe", "friction=0.2:1:5", "--doe", "damping=1:4:4",
             "--method", "modal", "--eigen-band", "100:8000", "--json", "--out-dir", out)
    assert r.exit_code == 0, r.output
    got = json.loads(r.stdout)
    model = load_model(chain)
    ref = doe_sweep(model, load_design(chain, model), {"friction": np.linspace(0.2, 1, 5),
                                                      "damping": np.linspace(1, 4, 4)}, 60.0, 1.0, method="modal",
                    band=(100.0, 8000.0))
    assert got["points"] == 20 and got["parameters"] == ["friction", "damping"] and got["trusted_points"] == 20
    assert (ref.max_growth_rate.values > 0).any() and (ref.max_growth_rate.values < 0).any()  # a real sweep
    pareto = ref.pareto.values
    assert len(got["pareto"]) == int(pareto.sum()) > 1
    assert sorted(p["max_growth_rate"] for p in got["pareto"]) == pytest.approx(
        sorted(ref.max_growth_rate.values[pareto].tolist()), rel=1e-12)
    assert [p["change_size"] for p in got["pareto"]] == sorted(p["change_size"] for p in got["pareto"])
    saved = xr.load_dataset(out / "design.nc")
    assert saved.attrs["kind"] == "doe_sweep" and json.loads((out / "design.json").read_text()) == got


@pytest.mark.parametrize(("args", "fragment"), [
    (("--doe", "friction=0.2:1:5", "--scatter", "KR=0.05"), "give one of them"),
    (("--scatter", "KR=abc"), "--scatter KR"),
    (("--scatter", "KR=0.1:cauchy"), "unknown distribution 'cauchy'"),
    (("--scatter", "KR"), "must be NAME=COV[:DIST]"),
    (("--samples", "50"), "--samples applies with --scatter only"),
    (("--doe", "pad=0.8:1.2:3"), "'pad'"),
    (("--doe", "friction=0.2:1:5", "--doe", "friction=1:2:2"), "friction is given twice"),
])
def test_bad_study_options_are_one_line_errors(config, args, fragment):
    r = _run("--config", config, "--rpm", 60, "--mu", 0.2, *args)
    assert r.exit_code == 2, r.output
    assert fragment in r.output and r.output.count("\n") == 1, r.output
