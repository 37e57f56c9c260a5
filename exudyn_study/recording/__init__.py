"""Recordings: time data of a test or a simulation, and the one read/write API.

A :class:`Recording` is a tuple of :class:`Channel` objects (``types``) written and read as
the native HDF5 format (``hdf5``) or as UFF58 (``uff``) through :func:`read_recording` and
:func:`write_recording` (``io``), which choose the format from the file's suffix.
"""

from exudyn_study.recording.io import read_recording, write_recording
from exudyn_study.recording.types import DIRECTIONS, FORMAT_VERSION, QUANTITY_UNITS, ROLES, Channel, Recording

__all__ = ["Channel", "Recording", "read_recording", "write_recording", "QUANTITY_UNITS", "FORMAT_VERSION",
           "ROLES", "DIRECTIONS"]
