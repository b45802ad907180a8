"""Entry point of the ``squealkit`` command.

Each subcommand lives in its own module and is imported only when it runs, so
``squealkit --help`` is instant. User errors (bad options, bad values, bad files) end the
run with one line on stderr and exit code 2; Ctrl-C exits with 130.
"""

from __future__ import annotations

import importlib
import sys
import warnings
from typing import Any

import click

from .. import __version__
from .._validation import InputError

#: Subcommand name -> "module:attribute". One line per subcommand.
COMMANDS: dict[str, str] = {
    "stability": "squealkit.cli.stability:stability",
    "critical": "squealkit.cli.critical:critical",
    "fe-demo": "squealkit.cli.fe_demo:fe_demo",
    "modes": "squealkit.cli.modes:modes",
    "presets": "squealkit.cli.presets:presets",
    "report": "squealkit.cli.reproduce:report",
    "reproduce": "squealkit.cli.reproduce:reproduce",
    "tolerance": "squealkit.cli.tolerance:tolerance",
    "simulate": "squealkit.cli.simulate:simulate",
    "analyze": "squealkit.cli.analyze:analyze",
    "montecarlo": "squealkit.cli.montecarlo:montecarlo",
    "synth": "squealkit.cli.synth:synth",
}


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings reach the user as one line on stderr, like errors (no source lines)."""
    click.echo(f"squealkit: warning: {message}", err=True)


class SquealkitGroup(click.Group):
    """A click group with lazily imported subcommands and one-line error reports."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        target = COMMANDS.get(cmd_name)
        if target is None:
            return None
        module, attr = target.split(":")
        return getattr(importlib.import_module(module), attr)

    def main(  # type: ignore[override]
        self,
        args: list[str] | None = None,
        prog_name: str | None = None,
        complete_var: str | None = None,
        standalone_mode: bool = True,
        **extra: Any,
    ) -> int:
        shown = warnings.showwarning
        warnings.showwarning = _one_line_warning
        try:
            rv = super().main(
                args, prog_name or "squealkit", complete_var, standalone_mode=False, **extra
            )
            code = rv if isinstance(rv, int) and not isinstance(rv, bool) else 0
        except click.UsageError as e:
            hint = f" (see '{e.ctx.command_path} --help')" if e.ctx is not None else ""
            click.echo(f"squealkit: error: {e.format_message()}{hint}", err=True)
            code = 2
        except click.ClickException as e:
            click.echo(f"squealkit: error: {e.format_message()}", err=True)
            code = e.exit_code
        except InputError as e:
            click.echo(f"squealkit: error: {e}", err=True)
            code = 2
        except click.Abort:
            click.echo("squealkit: interrupted", err=True)
            code = 130
        finally:
            warnings.showwarning = shown
        if standalone_mode:
            sys.exit(code)
        return code


@click.group(cls=SquealkitGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="squealkit")
@click.option("--threads", type=click.IntRange(min=1), default=None, metavar="N",
              help="Use at most N threads for the compiled kernels (default: $SQUEALKIT_THREADS, else every "
              "core). Small jobs run on one thread whatever N.")
@click.pass_context
def cli(ctx: click.Context, threads: int | None) -> None:
    """squealkit: predict and diagnose friction-induced disc brake squeal.

    \b
    Built on Lv, Zhang & Yu, "Influence of surface run-out on disc brake
    squeal", J. Vibroeng. 15(2) 2013: a 3-DOF pin-on-disc model whose disc
    run-out slope acts like extra friction (mu_e = mu + tan theta).

    \b
    Start here:
      squealkit stability --plot fig2.png      # paper Fig. 2, lock-in band
      squealkit critical --theta 0 --json      # critical friction
      squealkit modes --at-onset --plot mode.png       # shape of the squealing mode
      squealkit tolerance --mu 0.3 --wavelength 1e-3   # allowed run-out
      squealkit simulate --sro sine --plot fig4.png    # paper Fig. 4
      squealkit synth rec.nc                           # a SYNTHETIC rig recording
      squealkit analyze rec.nc --mic mic --displacement displacement --rpm 900 --radius 0.05
      squealkit presets                        # built-in models

    Every subcommand takes --help with an example. Units are SI; angles are
    in degrees on the command line and say so.

    \b
    Threads: --threads N (before the subcommand) or the environment variable
    SQUEALKIT_THREADS=N caps the threads of the compiled kernels, e.g. on a
    machine shared with other jobs; --threads wins over the variable:
      squealkit --threads 1 critical --sensitivity
    """
    from .._threads import env_threads, limit_threads

    env_threads()  # a bad SQUEALKIT_THREADS is reported before any work
    if threads is not None:
        ctx.with_resource(limit_threads(threads))


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code instead of exiting when ``argv`` is given."""
    if argv is None:
        return cli.main()
    return cli.main(argv, standalone_mode=False)


if __name__ == "__main__":  # pragma: no cover
    main()
