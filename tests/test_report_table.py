"""One parser for a model file's ``[report]`` table, for the small-model report and the FE report.

Both reports read the same table (``squealkit report --config``); the two parsers had drifted: the FE
one took a number written as text (``rpm = "1000"``) that the small-model one refused, neither took a
value with its unit as the model file's own tables do (``"25 mm"``, ``"2.9 kHz"``), and an infinite
sweep count escaped as a bare OverflowError. These tests hold both to one behaviour.
"""

import pytest

from squealkit import InputError, InputTypeError
from squealkit.report.fe_modes import FEReportSettings, load_fe_report_settings
from squealkit.report.settings import ReportSettings, load_report_settings

FE_BASE = FEReportSettings(rpm=(1000.0,), mu=(0.5,))
SMALL_BASE = ReportSettings()


def small(table):
    return ReportSettings.from_table(table, SMALL_BASE)


def fe(table):
    return FEReportSettings.from_table(table, FE_BASE)


# a value written with its unit, converted to the key's SI unit (reference: the unit definitions,
# 1 mm/s = 1e-3 m/s, 1 um = 1e-6 m, 1 kHz = 1e3 Hz; a bare number is in that unit already)
@pytest.mark.parametrize(("parse", "table", "key", "expected"), [
    (small, {"speed": "20 mm/s"}, "speed", 0.02),
    (small, {"sro_amplitude": "80 um"}, "sro_amplitude", 80e-6),
    (small, {"speed": "0.02"}, "speed", 0.02),           # a number as text: as the model file takes it
    (fe, {"eigen_band": ["9 kHz", "20 kHz"]}, "eigen_band", (9000.0, 20000.0)),
    (fe, {"rpm": "1000"}, "rpm", (1000.0,)),
    (fe, {"rpm_sweep": ["100 rpm", "2000 rpm", 5]}, "rpm_sweep", (100.0, 2000.0, 5)),
])
def test_both_parsers_take_a_value_with_its_unit(parse, table, key, expected):
    assert getattr(parse(table), key) == pytest.approx(expected, rel=1e-15)


@pytest.mark.parametrize(("parse", "table", "key"), [
    (small, {"speed": "20 kHz"}, "speed"),                  # a unit of another dimension
    (fe, {"eigen_band": ["9 mm", "20 mm"]}, "eigen_band"),
])
def test_both_parsers_refuse_a_unit_of_the_wrong_dimension(parse, table, key):
    with pytest.raises(InputError, match=rf"\[report\] {key}.*not in a unit of"):
        parse(table)


@pytest.mark.parametrize(("parse", "what"), [(small, "a small model's report"), (fe, "an FE model's report")])
def test_both_parsers_refuse_an_unknown_key_in_one_way(parse, what):
    with pytest.raises(InputError) as e:
        parse({"mu_desing": 0.1})
    msg = str(e.value)
    assert msg.startswith("[report]: unknown key 'mu_desing'") and what in msg and "; known: " in msg
    assert "\n" not in msg


@pytest.mark.parametrize(("parse", "table", "key"), [
    (small, {"mu_design": True}, "mu_design"),
    (fe, {"mu": True}, "mu"),
    (small, {"speed": float("inf")}, "speed"),
    (fe, {"rpm": float("nan")}, "rpm"),
    # an infinite or NaN sweep count escaped as OverflowError / a bare ValueError
    (fe, {"mu_sweep": [0.0, 1.0, float("inf")]}, "mu_sweep"),
    (fe, {"mu_sweep": [0.0, 1.0, float("nan")]}, "mu_sweep"),
    # a count is an integer in every key: max_views = 8.0 was refused, mu_sweep's N = 9.0 taken
    (fe, {"mu_sweep": [0.0, 1.0, 9.0]}, "mu_sweep"),
    (fe, {"max_views": 8.0}, "max_views"),
    (small, {"sro_amplitude": -1.0}, "sro_amplitude"),
    (fe, {"eigen_band": [2000, 1000]}, "eigen_band"),
])
def test_a_bad_value_is_one_input_error_naming_the_key(parse, table, key):
    with pytest.raises(InputError) as e:
        parse(table)
    assert type(e.value) in (InputError, InputTypeError)  # never a bare OverflowError or ValueError
    assert f"[report] {key}" in str(e.value) and "\n" not in str(e.value)


def test_the_api_constructors_check_and_convert_as_the_table_does():
    assert ReportSettings(speed="20 mm/s").speed == pytest.approx(0.02, rel=1e-15)
    with pytest.raises(InputError, match="rpm"):
        FEReportSettings(rpm=(float("nan"),), mu=(0.5,))
    assert FEReportSettings(rpm=1000, mu=0.5).load_cases == [(1000.0, 0.5)]


@pytest.mark.parametrize("loader", ["small", "fe"])
def test_both_loaders_read_the_file_in_one_way(tmp_path, loader):
    from squealkit.models import get_preset

    cfg = tmp_path / "rig.toml"
    cfg.write_text("report = 3\n")
    load = ((lambda p: load_report_settings(p, get_preset("lv2013"), paper=True)) if loader == "small"
            else (lambda p: load_fe_report_settings(p, _FakeFE())))
    with pytest.raises(InputError, match=r"^rig\.toml: \[report\] must be a table of NAME = VALUE\.$"):
        load(cfg)
    cfg.write_text("[report]\nnope = 1\n")
    with pytest.raises(InputError, match=r"^rig\.toml: \[report\]: unknown key 'nope'"):
        load(cfg)


class _FakeFE:
    """The two reference values :meth:`FEReportSettings.for_model` reads."""

    disc_speed_ref = 100.0
    mu_ref = 0.4


@pytest.mark.parametrize("kind", ["small", "fe"])
def test_a_bad_table_is_refused_before_the_defaults_are_placed(tmp_path, monkeypatch, kind):
    # the small model's defaults come from a search of its damped onset (work, and it may warn): the table
    # was parsed only after it, so a bad table cost that work and its error came after the warnings
    from squealkit.models import get_preset

    placed = []
    cls = ReportSettings if kind == "small" else FEReportSettings
    real = cls.for_model.__func__
    monkeypatch.setattr(cls, "for_model", classmethod(lambda c, *a, **k: placed.append(1) or real(c, *a, **k)))
    cfg = tmp_path / "rig.toml"
    cfg.write_text('[report]\nspeed = "20 kHz"\n' if kind == "small" else '[report]\neigen_band = ["9 mm", 1]\n')
    load = ((lambda p: load_report_settings(p, get_preset("lv2013").replace(k1=2e6), paper=False))
            if kind == "small" else (lambda p: load_fe_report_settings(p, _FakeFE())))
    with pytest.raises(InputError, match=r"^rig\.toml: Parameter \[report\] (speed|eigen_band)=.*not in a unit of"):
        load(cfg)
    assert placed == []
    cfg.write_text("[report]\nmu_design = 0.1\n" if kind == "small" else "[report]\nmu = 0.3\n")
    load(cfg)  # a good table: the defaults are placed for the keys it leaves out
    assert placed == [1]
