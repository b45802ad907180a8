"""One way a report is written from its steps: staged, in order, whole or not at all.

:func:`~squealkit.report.reproduce` (the paper's analysis of a small model) and
:func:`~squealkit.report.fe_modes.fe_report` (the unstable modes of an FE model) are each a list
of :class:`ReportStep` handed to :func:`run_report`, which

1. checks the output folder before any work (:func:`squealkit.io.check_output`);
2. stages ``figures/`` and ``data/`` beside it (:func:`squealkit.io.output_folder`), so an
   interrupted or failed run (an exception, Ctrl-C, SIGTERM) leaves no half-written file: the
   folder holds a complete report or is as it was;
3. runs the steps in order, reporting ``progress(done, total, step_name)`` before each and at the
   end, each step first waiting for the compiled kernels it names (:mod:`squealkit._warmup`);
4. renders the sections into ``report.html`` (:func:`squealkit.report.html.write_report`).

The design and correlation reports have no steps (one section from a finished study) and write
through :func:`~squealkit.report.html.save_figures` and :func:`~squealkit.report.html.write_report`.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from .document import Section

__all__ = ["ReproduceResult"]

#: What a report writes in its folder: with ``force``, a file of the user's among them is refused up front.
REPORT_FILES = ("report.html", "figures", "data")


@dataclass(frozen=True)
class ReportStep:
    """One step of a report: a name for the progress bar and a function that writes and returns sections.

    Attributes
    ----------
    name : str
        Shown by ``progress`` while the step runs.
    run : callable
        ``run(figures, data)`` writes its figures and data files into the two (staging) folders
        and returns its :class:`Section`, or a list of them.
    kernels : tuple of str
        Compiled kernel groups the step waits for if they are being compiled in the background
        (names of :data:`squealkit._warmup.GROUPS`).
    """

    name: str
    run: Callable[[Path, Path], Section | list[Section]]
    kernels: tuple[str, ...] = ()


@dataclass(frozen=True)
class ReproduceResult:
    """What a report run wrote and computed.

    Attributes
    ----------
    out_dir : Path
        The output folder: ``report.html``, ``figures/`` (PNG and SVG), ``data/`` (netCDF).
    sections : tuple of Section
        The report's content, with the computed numbers of each section in ``numbers``.
    seconds : float
        Wall time of the run.
    """

    out_dir: Path
    sections: tuple[Section, ...]
    seconds: float

    @property
    def report(self) -> Path:
        return self.out_dir / "report.html"

    def numbers(self) -> dict[str, dict[str, float]]:
        """The computed numbers by section key."""
        return {s.key: dict(s.numbers) for s in self.sections}


def run_report(
    out_dir: str | Path,
    steps: Sequence[ReportStep],
    *,
    title: str,
    subtitle: str = "",
    quick: bool = False,
    force: bool = False,
    progress: Callable[[int, int, str], None] | None = None,
    compile_kernels: Sequence[str] = (),
    closing: Callable[[Sequence[Section]], Section] | None = None,
) -> ReproduceResult:
    """Run ``steps`` into a staged ``out_dir`` and write ``report.html``; the folder appears complete or not at all.

    Parameters
    ----------
    out_dir : path-like
        Output folder; created, or replaced as a whole when the run succeeds. A folder holding
        files squealkit did not write is refused, unless ``force``.
    steps : sequence of ReportStep
        The steps, in order.
    title, subtitle : str
        The report's heading and the line under it.
    quick : bool
        A preview: each figure drawn once, as PNG (otherwise PNG and SVG).
    force : bool
        Write into a folder that holds other files: the report's files are moved in one by one,
        complete, and the other files are left alone.
    progress : callable, optional
        ``progress(done, total, step_name)`` before each step, and ``(total, total, "report")``
        before the page is rendered.
    compile_kernels : sequence of str
        Kernel groups compiled in a background process while the first steps run (see
        :func:`squealkit._warmup.compiling`); a step waits for those it names in ``kernels``.
    closing : callable, optional
        ``closing(sections)`` returns a last section made from the others (e.g. the
        conclusions); it is not a step of ``progress``.

    Returns
    -------
    ReproduceResult
    """
    from .. import _warmup
    from ..io import check_output, output_folder
    from .html import write_report
    from .steps_stability import figure_formats

    out = Path(out_dir)
    check_output(out, directory=True, force=force, names=REPORT_FILES)  # before the work, not after
    start = time.perf_counter()
    warm = _warmup.compiling(compile_kernels) if compile_kernels else contextlib.nullcontext()
    with warm, figure_formats(("png",) if quick else ("png", "svg")), output_folder(out, force=force) as stage:
        figures, data = stage / "figures", stage / "data"
        figures.mkdir(parents=True)
        data.mkdir()
        sections: list[Section] = []
        for i, step in enumerate(steps):
            if progress is not None:
                progress(i, len(steps), step.name)
            _warmup.wait(step.kernels)
            made = step.run(figures, data)
            sections.extend(made if isinstance(made, list) else [made])
        if closing is not None:
            sections.append(closing(sections))
        if progress is not None:
            progress(len(steps), len(steps), "report")
        write_report(sections, stage, title=title, subtitle=subtitle)
    return ReproduceResult(out, tuple(sections), time.perf_counter() - start)
