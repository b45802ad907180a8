"""Saving and loading results (being split into modules by concept; see the next commit)."""

from ._staging import *  # noqa: F403
from ._staging import (  # noqa: F401
    MANIFEST, ZARR_MANIFEST, InputError, __all__, _interrupted, _owned_folder, _state, deferred_interrupts,
    final_name, interrupt_signal, interrupts_deferred, note_interrupt, tempfile,
)
