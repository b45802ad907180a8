"""One validator for whole-number parameters (``squealkit._validation.validate_int``), where functions had
each their own check: a bool taken as 1, 2.7 harmonics truncated to 2, None a TypeError traceback.

The accepted messages are validate_int's: ``Parameter NAME=VALUE must be an integer >= MIN`` (an
InputError), followed by ``, not TYPE`` when VALUE is not an integer at all (also a TypeError)."""

import numpy as np
import pytest

from squealkit import InputError


def _vdp():
    """Van der Pol's oscillator (harmonic_balance's own docstring example), and its cycle."""
    from squealkit.nonlinear import SecondOrderSystem, harmonic_balance

    def vdp(x, v, eps):
        f = eps * (1 - x**2) * v
        return f, (-2 * eps * x * v)[..., None], (eps * (1 - x**2))[..., None], (1 - x**2) * v

    system = SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), vdp, ("x",))
    return system, harmonic_balance(system, 0.1, omega=1.0, harmonics=3)


def test_harmonic_balance_and_floquet_refuse_a_fraction_of_a_harmonic_or_step():
    from squealkit.nonlinear import floquet_multipliers, harmonic_balance

    system, cycle = _vdp()
    with pytest.raises(InputError, match=r"^Parameter harmonics=2\.7 must be an integer >= 1, not float\.$"):
        harmonic_balance(system, 0.1, omega=1.0, harmonics=2.7)   # was run with 2 harmonics
    with pytest.raises(InputError, match=r"^Parameter n_floquet=64\.5 must be an integer >= 1, not float\.$"):
        floquet_multipliers(system, cycle, n_floquet=64.5)   # was run with 64 steps
    with pytest.raises(InputError, match=r"^Parameter n_floquet=0 must be an integer >= 1\.$"):
        floquet_multipliers(system, cycle, n_floquet=0)
    assert floquet_multipliers(system, cycle, n_floquet=np.int64(64)).shape == (2,)   # a NumPy integer is one


def test_limit_cycle_branches_refuse_a_point_count_that_is_not_one():
    from squealkit.models import get_preset
    from squealkit.nonlinear import limit_cycle_branch, limit_cycle_branch_slope

    model = get_preset("lv2013")
    with pytest.raises(InputError, match=r"^Parameter n_points=2\.5 must be an integer >= 2, not float\.$"):
        limit_cycle_branch(model, (0.39, 0.6), n_points=2.5)   # was a branch of 2 points
    with pytest.raises(InputError, match=r"^Parameter n_points=1 must be an integer >= 2\.$"):
        limit_cycle_branch_slope(model, (-0.1, 0.1), mu=0.4, n_points=1)   # was a ZeroDivisionError
    with pytest.raises(InputError, match=r"^Parameter harmonics=4\.0 must be an integer >= 1, not float\.$"):
        limit_cycle_branch(model, (0.39, 0.6), harmonics=4.0)


@pytest.mark.parametrize("call, message", [
    ("synthetic_campaign", r"^Parameter n_applications=True must be an integer >= 1, not bool\.$"),
    ("synthetic_correlation_campaign", r"^Parameter n_applications=True must be an integer >= 1, not bool\.$"),
    ("split_runout", r"^Parameter macro_orders=True must be an integer >= 1, not bool\.$"),
    ("butter_sos", r"^Parameter order=True must be an integer >= 1, not bool\.$"),
    ("fe_critical_friction", r"^Parameter n_scan=None must be an integer >= 2, not NoneType\.$"),
    ("fe_critical_friction_float", r"^Parameter n_scan=3\.0 must be an integer >= 2, not float\.$"),
    ("squeal_propensity", r"^Parameter batch_size=True must be an integer >= 1, not bool\.$"),
])
def test_whole_number_parameters_have_one_check_and_one_message(tmp_path, call, message):
    # each was accepted (True as 1; 3.0 as 3) or a TypeError traceback (int(None)) before
    from squealkit.campaign import synthetic_campaign
    from squealkit.correlate.synthetic import synthetic_correlation_campaign
    from squealkit.measurement import butter_sos, split_runout

    def fe_onset(n_scan):
        from squealkit.fe import FEModel
        from squealkit.stability import fe_critical_friction

        m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 1.2]), KR=[[0.0, 1.0], [-1.0, 0.0]])
        return fe_critical_friction(m, [60.0], mu_max=1.0, n_scan=n_scan)

    def propensity():
        from squealkit.models import get_preset
        from squealkit.uncertainty import squeal_propensity

        unc = {"k1": {"dist": "normal", "mean": 1.0e5, "std": 1.0e3}}
        return squeal_propensity(get_preset("lv2013"), unc, [0.3, 0.4], samples=4, batch_size=True, damped=False)

    calls = {
        "synthetic_campaign": lambda: synthetic_campaign(tmp_path / "c", n_applications=True),
        "synthetic_correlation_campaign": lambda: synthetic_correlation_campaign(tmp_path / "k", n_applications=True),
        "split_runout": lambda: split_runout(np.zeros(1000), 1000.0, 600.0, lowpass_freq=200.0, macro_orders=True),
        "butter_sos": lambda: butter_sos("lowpass", 100.0, 1000.0, order=True),
        "fe_critical_friction": lambda: fe_onset(None),
        "fe_critical_friction_float": lambda: fe_onset(3.0),
        "squeal_propensity": propensity,
    }
    with pytest.raises(InputError, match=message) as e:
        calls[call]()
    assert isinstance(e.value, TypeError)   # not an integer at all: also Python's TypeError


def test_the_uncertainty_module_uses_the_one_validator():
    import squealkit.uncertainty as u

    assert not hasattr(u, "_positive_int")
