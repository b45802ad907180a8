"""One name per concept across the API (docs/api.md, "Conventions"), and renamed keywords that keep working.

Checked by introspection of the public API (the walk of ``test_api_docs``) and of the CLI's
commands, so a new function or option that breaks a convention fails here.
"""

from __future__ import annotations

import inspect
import re
import warnings

import numpy as np
import pytest

from test_api_docs import public_objects

docscrape = pytest.importorskip("numpydoc.docscrape")

#: Input names with a fixed meaning (and the unit their description must state), from STYLE.md
#: and the SDyPy vocabulary it cites: angles in rad unless the name ends in _deg; frequencies in Hz.
UNIT_OF = [
    (re.compile(r"^theta$"), "[rad]"),
    (re.compile(r"_deg$"), "deg"),
    (re.compile(r"^(freq|freq_lower|freq_upper|.+_freq)$"), "[Hz]"),
    (re.compile(r"^band$"), "[Hz]"),
]
#: Names that stand for a concept that already has its name: a frequency input is ``freq``/``*_freq``
#: (``frequency_hz`` names results), an angle in rad is ``theta``, a range is ``band=(lo, hi)``.
FORBIDDEN = {"frequency": "freq", "frequency_hz": "freq", "freq_hz": "freq", "theta_rad": "theta",
             "angle_deg": "theta_deg", "freq_range": "band", "frequency_band": "band"}


def _documented(obj, *sections: str) -> dict[str, str]:
    doc = docscrape.NumpyDocString(inspect.getdoc(obj) or "")
    out = {}
    for section in sections:
        for p in doc[section]:
            for n in p.name.split(","):
                out[n.strip().lstrip("*")] = p.type + " " + " ".join(p.desc)
    return out


def _inputs(obj) -> list[str]:
    """Parameters a caller passes; a result class's fields (its Attributes) are outputs, named as results."""
    try:
        params = [p for p in inspect.signature(obj).parameters if p not in ("self", "cls")]
    except (TypeError, ValueError):
        return []
    outputs = _documented(obj, "Attributes") if inspect.isclass(obj) else {}
    return [p for p in params if p not in outputs]


def naming_problems(name: str, obj) -> list[str]:
    """How the inputs of ``obj`` break the conventions (empty when they follow them)."""
    problems = []
    docs = _documented(obj, "Parameters", "Other Parameters", "Attributes")
    for p in _inputs(obj):
        if p in FORBIDDEN:
            problems.append(f"{name}({p}=): name it {FORBIDDEN[p]}")
        for pattern, unit in UNIT_OF:
            if pattern.search(p) and p in docs and unit not in docs[p]:
                problems.append(f"{name}({p}=): the description must state {unit!r}: {docs[p][:80]!r}")
        # omega is an eigen (circular) frequency; the disc's speed is disc_speed [rad/s] or rpm
        if p.startswith("omega") and "disc speed" in docs.get(p, "").lower():
            problems.append(f"{name}({p}=): the disc speed is disc_speed [rad/s] (or rpm), never omega")
    return problems


def test_inputs_use_the_conventional_names_and_state_their_units():
    problems = [msg for name, obj in sorted(public_objects().items()) for msg in naming_problems(name, obj)]
    assert not problems, "\n".join(problems)


def test_the_naming_check_catches_a_breach():
    def f(x, theta=0.0, frequency=1.0, lowpass_freq=1.0):
        """Sketch.

        Parameters
        ----------
        x : float
            Anything.
        theta : float
            Incline in degrees.
        frequency : float
            A frequency [Hz].
        lowpass_freq : float
            Corner [Hz].
        """

    assert naming_problems("f", f) == ["f(theta=): the description must state '[rad]': 'float Incline in degrees.'",
                                       "f(frequency=): name it freq"]


def test_cli_angles_are_in_degrees_and_say_so():
    """Python takes radians (``theta``); the CLI takes degrees, and every angle option says DEGREES."""
    import click

    from squealkit.cli.main import cli

    def commands(group):
        ctx = click.Context(group)
        for name in group.list_commands(ctx):
            cmd = group.get_command(ctx, name)
            if isinstance(cmd, click.Group):
                yield from commands(cmd)
            else:
                yield name, cmd

    seen = 0
    for name, cmd in commands(cli):
        for opt in cmd.params:
            if any("theta" in o for o in getattr(opt, "opts", ())):
                seen += 1
                assert "DEGREES" in (opt.help or "") or "deg" in (opt.metavar or "").lower(), (name, opt.opts)
    assert seen >= 4  # stability, critical, modes, montecarlo, limitcycle


@pytest.fixture(scope="module")
def run_out_response():
    from squealkit.models import get_preset
    from squealkit.transient import SineRunOut, simulate

    return simulate(get_preset("lv2013"), mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), duration=0.004)


def test_renamed_keywords_keep_working_with_a_warning(run_out_response):
    from squealkit.transient import response_envelope, transient_summary

    ds = run_out_response
    new = response_envelope(ds, "x1_ddot", highpass_freq=2000.0)
    with pytest.warns(DeprecationWarning, match=r"freq_lower=.*deprecated.*highpass_freq="):
        old = response_envelope(ds, "x1_ddot", freq_lower=2000.0)
    np.testing.assert_array_equal(old.values, new.values)
    assert old.attrs == new.attrs
    with pytest.warns(DeprecationWarning, match="highpass_freq"):
        assert transient_summary(ds, freq_lower=2000.0) == transient_summary(ds, highpass_freq=2000.0)
    with pytest.raises(TypeError, match="both freq_lower="):
        response_envelope(ds, "x1_ddot", freq_lower=1.0, highpass_freq=2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the new name (and the default) do not warn
        response_envelope(ds, "x1_ddot")


def test_renamed_plot_keyword_keeps_working(run_out_response):
    pytest.importorskip("matplotlib")
    from squealkit.plotting.transient import envelope_plot

    with pytest.warns(DeprecationWarning, match="highpass_freq"):
        old = envelope_plot(run_out_response, freq_lower=2000.0)
    new = envelope_plot(run_out_response, highpass_freq=2000.0)
    assert [a.get_lines()[0].get_ydata().tolist() for a in old.axes] == \
           [a.get_lines()[0].get_ydata().tolist() for a in new.axes]


def test_every_rename_points_at_a_real_parameter():
    """A rename's new name is a parameter of the function and its old one is not (nothing shadowed)."""
    import squealkit.plotting.transient as pt

    renamed = {n: o for n, o in public_objects().items() if hasattr(o, "__renamed_kwargs__")}
    renamed["squealkit.plotting.transient.envelope_plot"] = pt.envelope_plot
    assert len(renamed) >= 3
    for name, obj in renamed.items():
        params = inspect.signature(obj).parameters
        for old, new in obj.__renamed_kwargs__.items():
            assert new in params and old not in params, (name, old, new)


# -- CLI options: one name, one type, one meaning (cli/_options.py OPTIONS) -------------------------


def _cli_commands():
    import click

    from squealkit.cli.main import cli

    ctx = click.Context(cli)
    for name in cli.list_commands(ctx):
        cmd = cli.get_command(ctx, name)
        assert not isinstance(cmd, click.Group), name  # no nested groups yet; walk them when there are
        yield name, cmd


def cli_option_problems(commands) -> list[str]:
    """How the options of ``commands`` ((name, click command) pairs) break the one vocabulary:
    an option not declared in OPTIONS, or with another type, repeatability or unit than declared;
    a hidden option that is not a declared deprecated alias of an option of the same command."""
    import click

    from squealkit.cli._options import DEPRECATED_OPTIONS, OPTIONS, option_type

    problems = []
    for cmd_name, cmd in commands:
        names = {o for p in cmd.params if isinstance(p, click.Option) and not p.hidden for o in p.opts}
        for p in cmd.params:
            if not isinstance(p, click.Option):
                continue
            for opt in p.opts:
                where = f"{cmd_name} {opt}"
                if p.hidden:
                    new = DEPRECATED_OPTIONS.get((cmd_name, opt))
                    if new is None or new not in names:
                        problems.append(f"{where}: hidden, but not a declared deprecated alias of an option here")
                    continue
                term = OPTIONS.get(opt)
                if term is None:
                    problems.append(f"{where}: not declared in cli/_options.py OPTIONS")
                    continue
                if option_type(p) != term.type:
                    problems.append(f"{where}: type {option_type(p)}, declared {term.type} ({term.meaning})")
                if bool(p.multiple) != term.multiple:
                    problems.append(f"{where}: multiple={p.multiple}, declared {term.multiple}")
                if term.unit and term.unit not in (p.help or ""):
                    problems.append(f"{where}: the help must state {term.unit!r}: {(p.help or '')[:70]!r}")
    return problems


def test_cli_options_have_one_type_and_meaning_everywhere():
    """Every option of every command is declared once in cli/_options.py, with one type (a number,
    a range, a file, a folder...) and the unit its help states: ``--rpm`` is a disc speed [rpm]
    that takes a number or a range everywhere (commands needing one value refuse a range),
    ``--band`` the squeal band (the FE eigenvalue band is ``--eigen-band``), ``--out``/``--plot``
    files (folders are ``--out-dir``), one tacho option ``--pulses-per-rev``."""
    from squealkit.cli._options import DEPRECATED_OPTIONS, OPTIONS

    commands = list(_cli_commands())
    assert not cli_option_problems(commands), "\n".join(cli_option_problems(commands))
    used = {o for _, cmd in commands for p in cmd.params for o in getattr(p, "opts", ()) if not getattr(p, "hidden", 0)}
    assert set(OPTIONS) - used == set(), "declared but used by no command"
    assert {(c, o) for c, cmd in commands for p in cmd.params if getattr(p, "hidden", False) for o in p.opts} \
        == set(DEPRECATED_OPTIONS)


def test_the_cli_option_check_catches_a_breach():
    import click

    @click.command()
    @click.option("--rpm", type=float, help="Disc speed [rpm].")  # a number where --rpm is a number or a range
    @click.option("--band", default=None, help="Eigenvalue band.")  # the unit [Hz] not stated
    @click.option("--tacho-ppr", type=int, default=1)  # not declared: the name is --pulses-per-rev
    @click.option("--out", "out_dir", type=click.Path(file_okay=False))  # a folder: --out-dir
    @click.option("--old", hidden=True)  # a hidden option that is no declared alias
    def c(**kw):
        pass

    problems = cli_option_problems([("demo", c)])
    assert [p.split(":")[0] for p in problems] == ["demo --rpm", "demo --band", "demo --tacho-ppr", "demo --out",
                                                  "demo --old"], problems
