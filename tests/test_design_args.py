"""The design studies share their arguments: one resolver, one message per wrong input (issue #26 review).

:func:`eigen_derivatives` and :func:`countermeasures` take the same model, parameters, operating point and
solver options; :func:`doe_sweep` and :func:`robust_margins` the same operating point. Each wrong input below
must be refused by every one of them with the same one-line :class:`InputError`, naming the value. The
accepted ranges come from the model (an FE model needs a disc speed, >= 0, > 0 with a ``DR`` part, which is
scaled by its inverse; a small model has none and needs ``mu``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from squealkit import InputError
from squealkit.design import countermeasures, doe_sweep, eigen_derivatives, robust_margins
from squealkit.fe.model import FEModel

FE = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 1.2]), KR=[[0.0, 1.0], [-1.0, 0.0]], D1=0.001 * np.eye(2))
WITH_DR = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 1.2]), DR=0.01 * np.eye(2))


def _small():
    from squealkit.models import get_preset

    return get_preset("lv2013")


def _message(func, *args, **kwargs) -> str:
    with pytest.raises(InputError) as e:
        func(*args, **kwargs)
    text = str(e.value)
    assert "\n" not in text
    return text


# (model, keyword arguments, a fragment of the message)
POINT = [
    (FE, {}, "needs a disc speed"),
    (FE, {"rpm": 60.0, "disc_speed": 6.0}, "not both"),
    (FE, {"rpm": -5.0}, "rpm=-5.0 rev/min must be >= 0"),
    (FE, {"disc_speed": -1.0}, "disc_speed=-1.0 rad/s must be >= 0"),
    (WITH_DR, {"rpm": 0.0}, "rpm=0.0 rev/min must be > 0 (the model's DR part"),
    (FE, {"rpm": math.nan}, "rpm"),
    (FE, {"rpm": 60.0, "mu": math.inf}, "mu"),
    (FE, {"rpm": 60.0, "theta": 2.0}, "theta"),
    ("small", {"rpm": 60.0, "mu": 0.3}, "rpm applies to FE models only"),
    ("small", {"disc_speed": 6.0, "mu": 0.3}, "disc_speed applies to FE models only"),
    ("small", {}, "needs the friction coefficient"),
]


@pytest.mark.parametrize(("model", "kwargs", "fragment"), POINT)
def test_every_study_refuses_a_bad_operating_point_with_one_message(model, kwargs, fragment):
    model = _small() if model == "small" else model
    table = {"k": "k3"} if model is not FE and model is not WITH_DR else {"pad": "K1"}
    got = {
        "eigen_derivatives": _message(eigen_derivatives, model, table, **kwargs),
        "countermeasures": _message(countermeasures, model, table, **kwargs),
        "robust_margins": _message(robust_margins, model, scatter={"k3" if model not in (FE, WITH_DR) else "K1": 0.1},
                                   damped=None if model in (FE, WITH_DR) else True, **kwargs),
    }
    if model in (FE, WITH_DR):
        got["doe_sweep"] = _message(doe_sweep, model, table, {"pad": [0.9, 1.1]}, **kwargs)
    assert len(set(got.values())) == 1, got
    assert fragment in next(iter(got.values()))


SOLVER = [
    (FE, {"rpm": 60.0, "method": "banana"}, "method='banana'; known:"),
    (FE, {"rpm": 60.0, "band": (5.0, 1.0)}, "hi must exceed lo"),
    (FE, {"rpm": 60.0, "n_modes": 0}, "n_modes=0"),
    (FE, {"rpm": 60.0, "basis": np.ones((3, 1))}, "finite 2 x r matrix"),
    (FE, {"rpm": 60.0, "basis": np.eye(2), "method": "dense"}, "With basis=..."),
    ("small", {"mu": 0.3, "method": "dense"}, "apply to FE models only"),
    ("small", {"mu": 0.3, "basis": np.eye(3)}, "basis applies to FE models only"),
    (FE, {"rpm": 60.0, "parameters": {"pad": "K9"}}, "K9"),
]


@pytest.mark.parametrize(("model", "kwargs", "fragment"), SOLVER)
def test_derivatives_and_countermeasures_refuse_the_same_solver_options_alike(model, kwargs, fragment):
    model = _small() if model == "small" else model
    table = kwargs.pop("parameters", {"k": "k3"} if model is not FE else {"pad": "K1"})
    a = _message(eigen_derivatives, model, table, **kwargs)
    b = _message(countermeasures, model, table, **kwargs)
    assert a == b and fragment in a


def test_disc_speed_and_rpm_give_the_same_study():
    # rpm = disc_speed * 60 / (2 pi): the same operating point either way
    by_rpm = countermeasures(FE, {"friction": "KR"}, rpm=60.0, mu=0.2)
    by_speed = countermeasures(FE, {"friction": "KR"}, disc_speed=2 * math.pi, mu=0.2)
    np.testing.assert_allclose(by_rpm.confirmed_value.values, by_speed.confirmed_value.values, rtol=1e-12)
    assert by_speed.attrs["rpm"] == pytest.approx(60.0, rel=1e-12)
    on_basis = countermeasures(FE, {"friction": "KR"}, rpm=60.0, mu=0.2, basis=np.eye(2))
    assert on_basis.attrs["basis_size"] == 2
    np.testing.assert_allclose(on_basis.confirmed_value.values, by_rpm.confirmed_value.values, rtol=1e-6)
