"""Saving and loading results: written completely or not at all, and nothing else touched.

Every file squealkit writes goes first to a temporary sibling and is moved into place only
when complete (``os.replace``), so an interrupted run or a failure never leaves a
half-written file over a good one; the CLI moves all outputs of one run together at its end
(:func:`outputs_together`). A new file gets the permissions the umask gives; an overwritten
one keeps its own. Folders squealkit writes (reports, zarr stores, campaigns) carry a
manifest of their files, and only a manifest makes a file or folder squealkit's: a folder
holding other files is never replaced or emptied (:func:`output_folder`), and a device, a
fifo or a socket is never replaced. While a run writes an output it holds a lock beside it,
so a second run writing the same output is refused in one line.

The package, from the bottom up:

- ``_interrupts``: an interrupt recorded for the run; library writes that hold it until they return.
- ``_ownership``: what stands at an output path and whether squealkit wrote it (manifests).
- ``_locks``: the lock beside an output while a run writes it.
- ``_staging``: staging and moving into place (:func:`atomic_path`, :func:`output_folder`,
  :func:`outputs_together`, :func:`check_output`, :func:`written_path`).
- ``_datasets`` and ``_files``: the writers and readers on top (netCDF/zarr results, figures, text).

What a loaded result is (its ``kind``, :func:`result_kind`) and a file saved by an older squealkit
brought to today's names (:func:`upgrade_result`) come from the result schema (``squealkit._accessor``).
"""

from .._accessor import RESULT_KINDS, result_kind, upgrade_result
from .._validation import InputError as InputError
from ._datasets import load_dataset, save_blocks, save_dataset
from ._files import save_figure, write_text
from ._interrupts import clear_interrupt, deferred_interrupts, interrupt_signal, interrupts_deferred, note_interrupt
from ._ownership import MANIFEST as MANIFEST
from ._ownership import ZARR_MANIFEST as ZARR_MANIFEST
from ._ownership import final_name as final_name
from ._staging import atomic_path, check_output, output_folder, outputs_together, written_path

__all__ = ["RESULT_KINDS", "atomic_path", "check_output", "clear_interrupt", "deferred_interrupts", "interrupt_signal",
           "interrupts_deferred", "load_dataset", "note_interrupt", "output_folder", "outputs_together", "result_kind",
           "save_blocks", "save_dataset", "save_figure", "upgrade_result", "write_text", "written_path"]

