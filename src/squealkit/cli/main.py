"""Entry point of the ``squealkit`` command.

Each subcommand lives in its own module and is imported only when it runs, so
``squealkit --help`` is instant. User errors (bad options, bad values, bad files) end the
run with one line on stderr and exit code 2, operating-system errors (permissions, a full
disk, a read-only folder) too. A run's outputs are staged and moved into place together at
its end (:func:`squealkit.io.outputs_together`); Ctrl-C exits with 130, SIGTERM with 143,
SIGHUP (a closed terminal) with 129 and SIGQUIT with 131, each removing every staged output.
"""

from __future__ import annotations

import errno
import importlib
import io
import os
import signal
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
    "design": "squealkit.cli.design:design",
    "fe-demo": "squealkit.cli.fe_demo:fe_demo",
    "modes": "squealkit.cli.modes:modes",
    "presets": "squealkit.cli.presets:presets",
    "report": "squealkit.cli.reproduce:report",
    "reproduce": "squealkit.cli.reproduce:reproduce",
    "tolerance": "squealkit.cli.tolerance:tolerance",
    "simulate": "squealkit.cli.simulate:simulate",
    "floquet": "squealkit.cli.floquet:floquet",
    "rig": "squealkit.cli.rig:rig",
    "analyze": "squealkit.cli.analyze:analyze",
    "montecarlo": "squealkit.cli.montecarlo:montecarlo",
    "synth": "squealkit.cli.synth:synth",
    "campaign": "squealkit.cli.campaign:campaign",
    "correlate": "squealkit.cli.correlate:correlate",
    "limitcycle": "squealkit.cli.limitcycle:limitcycle",
}


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings reach the user as one line on stderr, like errors (no source lines)."""
    click.echo(f"squealkit: warning: {message}", err=True)


class Terminated(KeyboardInterrupt):
    """SIGTERM, SIGHUP or SIGQUIT, raised like Ctrl-C so that every staged output is cleaned up
    on the way out."""


#: The signals that end a run cleanly (staged outputs removed), and exit with 128 + the signal.
SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT") if hasattr(signal, name))


def _on_signal(signum, frame) -> None:
    from ..io import interrupt_signal, interrupts_deferred, note_interrupt

    first = interrupt_signal() is None
    note_interrupt(signum if first else interrupt_signal())  # even if a library swallows the exception
    if not first:  # the run is already stopping: a second signal must not break off its cleanup
        return
    if interrupts_deferred():  # a library write is under way: it stops right after (io.deferred_interrupts)
        return
    raise KeyboardInterrupt() if signum == signal.SIGINT else Terminated()


def _ending_signal(e: BaseException | None) -> int:
    """The signal that ended the run (SIGINT for Ctrl-C without a handler)."""
    from ..io import interrupt_signal

    signum = interrupt_signal()
    if signum is not None:
        return int(signum)
    return int(signal.SIGTERM) if isinstance(e, Terminated) else int(signal.SIGINT)


def _skip_final_collection() -> None:
    """Leave the objects alive now out of the interpreter's last garbage collection at exit.

    Python collects every tracked object once more while it shuts down; after a large run that
    alone took 0.7-2 s of a SIGTERM's 0.8-2.4 s on a loaded machine. The objects are frozen
    (``gc.freeze``): the operating system reclaims their memory, and no output is written after
    an interrupt (every staged output is already removed), so none of their finalisers matters.
    """
    import gc

    gc.freeze()


def _os_error(e: OSError) -> str:
    """One line for an operating-system error: what failed, on which file."""
    what = e.strerror or str(e)
    if e.errno == errno.ENOSPC and what == os.strerror(errno.ENOSPC):
        what = "no space left on the device"
    from ..io import final_name

    name = final_name(os.fsdecode(e.filename)) if isinstance(e.filename, str | bytes) else None
    return f"{what}: {name!r}" if name else what


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
        from ._options import PENDING_NOTES

        shown = warnings.showwarning
        warnings.showwarning = _one_line_warning
        from ..io import outputs_together

        handlers = {}
        if standalone_mode:  # the real command line, not an in-process call
            for sig in SIGNALS:
                handlers[sig] = signal.signal(sig, _on_signal)
        PENDING_NOTES.clear()
        if sys.stdout is None:  # fd 1 closed ('>&-'): output fails as one line, like a full stdout
            sys.stdout = _ClosedStdout()
        try:
            with outputs_together():  # the run's outputs appear together at its end, or none
                rv = super().main(
                    args, prog_name or "squealkit", complete_var, standalone_mode=False, **extra
                )
            code = rv if isinstance(rv, int) and not isinstance(rv, bool) else 0
            try:
                sys.stdout.flush()  # a full or closed stdout fails here, inside the handlers
            except BrokenPipeError:
                raise
            except OSError as e:
                raise OSError(e.errno, f"cannot write to standard output ({e.strerror})") from e
            for note in PENDING_NOTES:
                click.echo(note, err=True)
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
        except (click.Abort, KeyboardInterrupt) as e:
            signum = _ending_signal(e.__cause__ if isinstance(e, click.Abort) else e)
            said = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}.get(
                signum, f"terminated by {signal.Signals(signum).name}")
            click.echo(f"squealkit: {said}", err=True)
            code = 128 + signum
            # the outputs are discarded already; the interpreter's final collection of every object the run
            # made (compiled kernels, arrays: 1-2 s on a loaded machine) need not delay the exit
            if standalone_mode:  # (a process that goes on, as a test's, keeps collecting)
                _skip_final_collection()
        except BrokenPipeError:
            # the reader went away (e.g. '| head'): quietly, as other tools do
            _silence_stdout()
            code = 1
        except OSError as e:
            named = "standard output" in (e.strerror or "")
            where = "cannot write to standard output: " if not named and e.filename is None and _on_stdout(e) else ""
            _silence_stdout()
            click.echo(f"squealkit: error: {where}{_os_error(e)}", err=True)
            code = 2
        finally:
            warnings.showwarning = shown
            for sig, h in handlers.items():
                signal.signal(sig, h)
            PENDING_NOTES.clear()
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
      squealkit synth --out rec.nc                     # a SYNTHETIC rig recording
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


def _on_stdout(e: OSError) -> bool:
    """Whether ``e`` arose writing to stdout (click.echo's stream, or the final flush)."""
    tb = e.__traceback__
    while tb is not None:
        frame = tb.tb_frame
        if frame.f_code.co_name == "echo" and "click" in frame.f_code.co_filename:
            stream = frame.f_locals.get("file")
            fd = getattr(stream, "fileno", None)
            try:
                return stream is sys.stdout or (fd is not None and fd() == 1)
            except (OSError, ValueError):
                return False
        tb = tb.tb_next
    return False


class _ClosedStdout(io.TextIOBase):
    """Stands for a standard output that was closed before the run: writing to it fails."""

    def write(self, s: str) -> int:
        raise OSError(errno.EBADF, "cannot write to standard output (it is closed)")

    def fileno(self) -> int:
        raise OSError(errno.EBADF, "standard output is closed")


def _silence_stdout() -> None:
    """After stdout failed, point it at /dev/null so that the exit's own flush is quiet."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code instead of exiting when ``argv`` is given."""
    if argv is None:
        return cli.main()
    return cli.main(argv, standalone_mode=False)


if __name__ == "__main__":  # pragma: no cover
    main()
