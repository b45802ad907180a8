"""Rig recordings on disk: one module per format family, a dispatcher, the writers.

:func:`open_recording` (``readers``) picks the reader by the file's suffix: CSV/text
(``delimited``), WAV (``wav``), netCDF/HDF5 (``netcdf``), NI TDMS (``tdms``), ASAM MDF4
(``mdf``), UFF 58 (``uff``); each returns a :class:`RecordingSource` (``source``) whose
blocks that format's ``blocks`` reads. :mod:`.writers` writes the same formats.
"""

from .readers import open_recording, read_recording, recording_dataset
from .source import DEFAULT_BLOCK, RecordingSource
from .writers import FORMATS, write_recording, write_recording_blocks

__all__ = ["DEFAULT_BLOCK", "FORMATS", "RecordingSource", "open_recording", "read_recording", "recording_dataset",
           "write_recording", "write_recording_blocks"]
