"""Issue 27, "Reports true for the user's rig": a stable rig, an own rig with dampers and an operating
point of its own, a recording read with analyze's options, and the paper report's figures.

Two quick reports are computed once each (module-scoped fixtures); the paper's pieces are checked on
their own steps, which cost a few seconds instead of a whole report.
"""

import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from squealkit.cli.main import cli
from squealkit.io import load_dataset

PIN = """[rig]
pin_diameter = 0.028
pin_length = 0.045
pin_youngs_modulus = 2.95e9
pin_density = 1040.0
pin_poisson = 0.35
disc_mass = 4.35
pin_axial_freq = 8653.0
"""
# disc mode far above the pin's bending mode (2722 Hz, Timoshenko): no mode coupling up to mu = 2, undamped
STABLE = PIN + "disc_freq = 5200.0\n\n[parameters]\nalpha_deg = 2.0\nc1 = 0.0\nc2 = 0.0\nc3 = 0.0\n"
# disc mode near the pin's bending mode, with dampers: damped onset mu_crit = 0.0516 at 2679 Hz (LAPACK, via
# critical_friction); its own operating point in a [report] table
DAMPED = (PIN + "disc_freq = 2650.0\n\n[parameters]\nalpha_deg = 2.0\nc1 = 30.0\nc2 = 30.0\nc3 = 30.0\n\n"
          "[report]\nmu_design = 0.04\nmu_transient = 0.045\nmu_unstable = 0.08\nmu_cycle = 0.07\n"
          "sro_amplitude = 6e-6\nsro_wavelength = 2e-3\nspeed = 0.04\n")


def _text(html: str) -> str:
    """The report's words: tags, styles and inline figures left out."""
    html = re.sub(r"<(style|svg|script)\b.*?</\1>", " ", html, flags=re.S)
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html)).replace("&#x27;", "'").replace("&#39;", "'")


def _run_report(d: Path, toml: str, *extra: str) -> SimpleNamespace:
    cfg = d / "rig.toml"
    cfg.write_text(toml)
    r = CliRunner().invoke(cli, ["report", "--config", str(cfg), "--quick", "--out-dir", str(d / "out"), "--json",
                                 *extra])
    assert r.exit_code == 0, (r.output, r.stderr)
    html = (d / "out" / "report.html").read_text()
    return SimpleNamespace(numbers=json.loads(r.stdout)["numbers"], html=html, text=_text(html), out=d / "out")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A SYNTHETIC recording (squeal at 2844 Hz, 600 rpm, tacho channel) whose microphone is stored in
    hundredths of a pascal: only --scale mic=100 gives the calibrated pressure back."""
    from squealkit.io import save_dataset
    from squealkit.measurement import synthetic_recording

    rec = synthetic_recording(duration=0.6, fs=40_000.0, rpm=600.0, radius=0.05, freq=2844.0, seed=3)
    rec["mic"] = rec["mic"] / 100.0
    path = tmp_path_factory.mktemp("rec") / "scaled.nc"
    save_dataset(rec, path)
    return path


@pytest.fixture(scope="module")
def stable(tmp_path_factory, recording):
    # with a recording (constant --rpm this time): the synthetic §5 would cost more than the real one
    return _run_report(tmp_path_factory.mktemp("stable"), STABLE, "--recording", str(recording), "--rpm", "600",
                       "--scale", "mic=100", "--radius", "0.05")


@pytest.fixture(scope="module")
def damped(tmp_path_factory, recording):
    return _run_report(tmp_path_factory.mktemp("damped"), DAMPED, "--recording", str(recording),
                       "--tacho", "tacho", "--scale", "mic=100", "--radius", "0.05")


# -- 1. a rig that is stable undamped gets a report that says so ------------------------------------------


@pytest.mark.slow
def test_stable_rig_gets_a_report_that_says_so(stable):
    # issue 27: "sensitivity is undefined", exit 2, after 34 s; the model is stable up to mu = 2 (LAPACK)
    n, text = stable.numbers, stable.text
    assert n["critical"]["mu_crit"] is None and n["critical"]["mu_crit_damped"] is None  # JSON null: NaN
    assert "stays stable over the friction range searched" in text
    assert "no sensitivities and no onset mode shape are computed" in text
    assert "No mode loses stability anywhere on the grid" in text
    assert "the damped model stays stable for every mu up to 2: there is no squeal onset" in text
    assert "no onset up to mu = 2 with either kinematics" in text
    # without an onset the operating point cannot be placed from it, and the report says whose it is
    assert "this model has no damped onset on a flat disc up to mu = 2 to place one from" in text
    # no number the report could not compute is printed as one
    assert not re.search(r"\bnan\b|\binf\b", text, flags=re.I), re.findall(r".{60}\bnan\b.{20}", text)
    # c1 = c2 = c3 = 0: no "with the model's damping" as if it had some
    assert "The model has no damping" in text and "With the model's damping" not in text
    # §5: the recording's squeal is not set beside a model frequency the model does not have
    assert "the model never loses stability up to mu = 2" in text
    assert n["measurement"]["squeal_frequency_hz"] == pytest.approx(2844.0, abs=3.0)


@pytest.mark.slow
def test_stable_rig_fig4_says_nothing_grows(stable):
    # frozen-time sigma <= 0 over the whole run: no grow-on-rising claim and no "not the paper's pattern" verdict
    text = stable.text
    assert "never reaches a stability boundary" in text
    assert "not the paper's grow-on-rising" not in text


# -- 2. an own rig: its own operating point, no paper comparisons, sentences true to its numbers ----------


@pytest.mark.slow
def test_own_operating_point_from_the_report_table(damped):
    # [report] in the model file: every transient, tolerance and run-out sentence uses the rig's values
    text, n = damped.text, damped.numbers
    assert n["transient"]["mu_transient"] == 0.045 and n["critical"]["mu_design"] == 0.04
    assert "Run-out tolerance at mu = 0.04" in text
    assert "Fig. 4 (sine SRO, q0 = 0.006 mm, lambda = 2 mm" in text
    assert "mu = 0.08, where it grows" in text and "v = 0.04 m/s" in text
    # the Fig. 4 run lasts long enough for whole run-out stages of the rig's own wavelength and speed
    assert n["transient"]["rising_stages"] >= 1 and n["transient"]["falling_stages"] >= 1
    assert "at mu = 0.07 (" in text  # the limit cycle quoted at mu_cycle
    # nothing from the paper's operating point (mu 0.3, 0.4, 0.6, q0 = 80 um, lambda = 1 mm)
    for paper in (r"mu = 0\.4\b", r"mu = 0\.6\b", r"mu = 0\.3\b", r"(?<![\d.])80 um", r"0\.08 mm", r"lambda = 1 mm",
                  r"the paper's mu = ", r"paper's Fig\. 4"):
        assert not re.search(paper, text), paper


@pytest.mark.slow
def test_own_rig_gets_no_published_comparisons(damped):
    # only the paper's model is compared with the paper's numbers: every comparison row of another rig has an
    # empty published cell, and no paper number appears
    assert "Published beside computed" not in damped.html  # its tables of checks are called so
    tables = re.findall(r"<caption>Checks</caption>(.*?)</table>", damped.html, flags=re.S)
    rows = [c for t in tables for c in re.findall(r"<tr><td>[^<]*</td><td>([^<]*)</td>", t)]
    assert rows and set(rows) == {"&mdash;"}
    text = damped.text
    for paper in ("14997", "15317", "2387", "m1 from the rig", "paper: 2388", "for reference", "as the paper finds"):
        assert paper not in text, paper


@pytest.mark.slow
def test_incline_sentence_agrees_with_its_own_table(damped):
    # issue 27: "the negative incline destabilises" while the rig's own table has mu_crit above the flat disc's
    # at every negative incline; the table is the data file behind the section
    ds = load_dataset(damped.out / "data" / "critical_kinematics.nc")
    cc = ds.mu_critical.sel(kinematics="consistent").values
    theta = ds.theta_deg.values if "theta_deg" in ds else np.linspace(-8, 8, cc.size)
    i0 = int(np.argmin(np.abs(theta)))
    m = np.where(np.isfinite(cc), cc, np.inf)
    for side, part in (("negative", m[:i0]), ("positive", m[i0 + 1:])):
        said = re.search(rf"the {side} incline (destabilises|stabilises)", damped.text)
        assert said, side
        lowers = bool(np.any(part < cc[i0]))
        assert (said[1] == "destabilises") == lowers, (side, part, cc[i0])


def test_growth_rates_are_per_stage_not_averaged():
    # issue 27: "+107 1/s on average" averaged +3.0 and +211.4 across a linear blow-up
    from squealkit.report.steps_transient import _fig4_text

    text = _fig4_text([3.0, 211.4], [-40.0, -35.0])
    assert "average" not in text and "+107" not in text
    assert "+3.0 1/s" in text and "+211.4 1/s" in text


def test_loss_of_contact_is_named_only_where_the_contact_opens():
    # issue 27: "bounded by loss of contact" with the contact open 0 % of the time
    from squealkit.report.steps_nonlinear import _settle_text

    closed = _settle_text((0.06, 2e-9, 0.0, 80.0), (1.0, 1.7e-6, 0.48, 146.0), 2666.0)
    first, second = closed.split(" and ", 1)
    assert "bounded by loss of contact" not in first and "0.0 % of the period" in first
    assert "48 % of the period: bounded by loss of contact" in second


def test_default_operating_point(tmp_path):
    # the paper's values for the paper's model only; another model's are placed from its own damped onset
    from squealkit.models import get_preset, load_model
    from squealkit.report.settings import ReportSettings, load_report_settings
    from squealkit.stability import critical_friction

    paper = load_report_settings(None, get_preset("lv2013"), paper=True)
    assert (paper.mu_transient, paper.mu_design, paper.sro_amplitude, paper.sro_wavelength) == (0.4, 0.3, 80e-6, 1e-3)
    assert paper.sro_slope == pytest.approx(0.503, abs=1e-3)  # paper Fig. 4: 2 pi 0.08 / 1
    cfg = tmp_path / "rig.toml"
    cfg.write_text(DAMPED.split("[report]")[0])
    model = load_model(cfg)
    own = load_report_settings(cfg, model, paper=False)
    c = critical_friction(model, 0.0, damped=True).mu_critical
    assert own.mu_transient == pytest.approx(0.9 * c, rel=1e-2) and own.mu_unstable == pytest.approx(1.5 * c, rel=1e-2)
    # Fig. 4's mu + tan(theta) swings through the onset, as in the paper
    assert own.mu_transient < c < own.mu_transient + own.sro_slope
    assert not own.is_paper and "damped onset" in own.source
    cfg.write_text(DAMPED.split("[report]")[0] + "[report]\nmu_desing = 0.1\n")
    from squealkit import InputError

    with pytest.raises(InputError, match="mu_desing"):
        load_report_settings(cfg, model, paper=False)
    assert ReportSettings.from_table({"mu_transient": 0.05}, own).mu_design == own.mu_design


# -- 3. report --recording reads and analyses as analyze does ---------------------------------------------


@pytest.mark.slow
def test_report_recording_takes_analyze_options(damped):
    # the microphone was stored in hundredths of a pascal and the speed comes from the tacho only (no --rpm):
    # squeal is found at the synthesised 2844 Hz only if --scale and --tacho were applied
    m = damped.numbers["measurement"]
    assert m["squeal_frequency_hz"] == pytest.approx(2844.0, abs=3.0)
    assert "disc speed from tacho channel 'tacho'" in damped.text and "scaled mic x 100" in damped.text


def test_report_has_every_recording_option_of_analyze():
    from squealkit.cli.analyze import analyze
    from squealkit.cli.reproduce import report

    only_analyze = {"files", "as_json", "plot_dir", "out_path", "summary_path", "scheduler"}
    mine = {p.name: p for p in report.params}
    for p in analyze.params:
        if p.name in only_analyze:
            continue
        assert p.name in mine, p.name
        assert mine[p.name].help == p.help, p.name  # one definition, one meaning (cli/_options.py)
    r = CliRunner().invoke(cli, ["report", "--tacho", "tacho"])
    assert r.exit_code == 2 and "--tacho applies to --recording" in r.stderr


# -- 4. the paper report's figures and prose --------------------------------------------------------------


def test_onset_mode_figure_labels_the_merging_pair_not_a_round_off_sign():
    # issue 27: sigma = +2.7e-9 was labelled "stable" and -2.7e-9 "loses stability"; at the undamped
    # coalescence (paper §3: 2436 Hz) both roots are one double root
    from squealkit.models import get_preset
    from squealkit.plotting.modes import modes_plot
    from squealkit.stability import onset_modes

    ds = onset_modes(get_preset("lv2013"))
    pair = ds.loses_stability.values
    assert pair.sum() == 2 and np.ptp(ds.frequency_hz.values[pair]) < 1e-3
    fig = modes_plot(ds)
    titles = [a.get_title() for a in fig.axes]
    assert not [t for t in titles if re.search(r"sigma = [+-]\d\.\d+e-0?9", t)], titles
    legend = " ".join(t.get_text() for leg in fig.legends for t in leg.get_texts())
    assert "coalescing pair" in legend and "stable mode" in legend  # the third mode (10.5 kHz) is stable


@pytest.fixture(scope="module")
def paper_how_loud(tmp_path_factory):
    from squealkit.models import get_preset
    from squealkit.report.steps_nonlinear import nonlinear_step

    d = tmp_path_factory.mktemp("loud")
    return nonlinear_step(get_preset("lv2013"), d, d, quick=True), d


@pytest.mark.slow
def test_how_loud_has_a_db_figure(paper_how_loud):
    s, d = paper_how_loud
    assert "how_loud_level" in [f.stem for f in s.figures] and (d / "how_loud_level.png").stat().st_size > 1000
    branch = load_dataset(d / "limit_cycles_mu.nc")
    level = branch["velocity_level_db"].values
    # closed form for the fundamental: v_rms = omega A / sqrt(2); the higher harmonics of a cycle bounded by
    # loss of contact add a little, so the level is at or above the fundamental's
    a = branch["amplitude"].sel(dof="x1").values
    fund = 20 * np.log10(branch["omega_rad_s"].values * a / np.sqrt(2) / 1e-9)
    ok = np.isfinite(level) & (a > 1e-9)
    assert ok.sum() > 3 and np.all(level[ok] >= fund[ok] - 0.5) and np.all(level[ok] <= fund[ok] + 3.0)
    text = " ".join(s.paragraphs)
    assert f"{s.numbers['level_db_mu05']:.1f} dB at mu = 0.5" in text


@pytest.mark.slow
def test_synthetic_frequency_agreement_is_called_circular(tmp_path):
    from squealkit.models import get_preset
    from squealkit.report.steps_measurement import measurement_step
    from squealkit.stability import critical_friction

    s = measurement_step(get_preset("lv2013"), tmp_path, tmp_path, quick=True)
    text = " ".join(s.paragraphs)
    assert "circular" in text
    # the paper's measured 2388 Hz is set beside the model's onset frequency, not beside the frequency the
    # analysis found in a recording made at that onset frequency
    onset = critical_friction(get_preset("lv2013"), 0.0, damped=True).frequency_hz
    paper_row = [c for c in s.comparisons if c.published == 2388.0]
    assert len(paper_row) == 1 and paper_row[0].computed == pytest.approx(onset)
    recovered = [c for c in s.comparisons if "recovered" in c.quantity]
    assert recovered and recovered[0].published is None and "Circular" in recovered[0].note


def test_fig13_labels_do_not_overlap():
    # issue 27: the band in the displacement's y label made it taller than its panel, over the pressure's label
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from squealkit.measurement import figure_signals, synthetic_recording
    from squealkit.plotting.measurement import band_vs_pressure_plot

    rec = synthetic_recording(duration=0.2, fs=40_000.0, rpm=900.0, radius=0.05, freq=2388.0, seed=1)
    fig = band_vs_pressure_plot(figure_signals(rec, rpm=900.0, band=(1430.87, 2980.98)))
    FigureCanvasAgg(fig).draw()
    r = fig.canvas.get_renderer()
    a1, a2 = fig.axes[:2]
    l1, l2 = (a.yaxis.label.get_window_extent(r) for a in (a1, a2))
    assert not l1.overlaps(l2)
    for ax, lab in ((a1, l1), (a2, l2)):
        assert lab.height <= ax.get_window_extent(r).height


@pytest.mark.slow
def test_quick_report_is_a_preview_drawn_once_per_figure(stable):
    # --quick saves each figure as the PNG the HTML embeds, not a second time as SVG (a third of the
    # preview's time went to drawing every figure twice); the captions name only what was written
    figures = stable.out / "figures"
    assert sorted(p.suffix for p in figures.iterdir()) == [".png"] * len(list(figures.iterdir()))
    assert "<code>.svg</code>" not in stable.html and "figures/" in stable.html


def test_fig4_envelope_far_beyond_the_frozen_time_growth_is_not_called_self_excited():
    # Found on an own rig (disc 2.65 kHz, c = 30 N s/m, q0 = 2.5 um): the envelope swung at +26.1 and
    # -26.1 1/s while the frozen-time growth rate of the same stages averaged +1.5 and -4.5 1/s (at most
    # +3.2 1/s), and the report said "mu_e swings through the stability boundary, so the response grows on
    # every rising stage": the swings are the run-out's own excitation, not the instability.
    from squealkit.report.steps_transient import _fig4_text

    driven = _fig4_text([26.1, 26.1], [-26.1, -25.9, -25.9], None, (-6.2, 3.2),
                        stage_sigma=([1.49, 1.49], [-4.5, -4.5, -4.5]))
    assert "swings through the stability boundary, so" not in driven
    assert "not the instability" in driven and "+1.5" in driven and "-4.5" in driven
    # the paper's own run (reproduce, this session: +34.3 against +25.0, -39.6 against -25.7) keeps its sentence
    paper = _fig4_text([34.3], [-39.6], None, (-40.0, 30.0), stage_sigma=([25.0], [-25.7]))
    assert "swings through the stability boundary, so the response grows on every rising stage" in paper


def test_conclusions_do_not_call_a_stable_runs_envelope_intermittent_squeal():
    # the stable rig (disc 5.2 kHz): "decays on 2 of 3 falling stages (the last at +49.7 1/s)" beside the
    # paper's "squeal is intermittent", while the frozen-time growth rate never rose above -3.75 1/s
    from squealkit.report.document import Section
    from squealkit.report.steps_conclusions import conclusions_step

    tr = {"rising_stages_growing": 0.0, "rising_stages": 2.0, "falling_stages_decaying": 2.0,
          "falling_stages": 3.0, "rise_rate": -3.6, "fall_rate": 49.7, "fig4_self_excited": 0.0,
          "fig4_sigma_max": -3.75}
    section = Section("transient", "§4", (), numbers=tr)
    text = " ".join(" ".join(map(str, r)) for t in conclusions_step([section]).tables for r in t.rows)
    assert "stays stable all through the run" in text and "-3.75 1/s" in text and "+49.7" not in text
