"""Exception hierarchy of exudyn_study.

Every error raised on bad user input derives from :class:`InputError`, itself a
:class:`ValueError`, so callers can catch one class. Messages name the input, the
offending value and what would be accepted, on one line.
"""

from __future__ import annotations

__all__ = ["InputError", "CacheError", "SimulationError", "StudyError"]


class StudyError(Exception):
    """Base class of all exudyn_study errors that are not input errors."""


class InputError(ValueError):
    """Bad input: a missing or malformed file, an out-of-range value, an unknown name."""


class CacheError(StudyError):
    """A cache entry is corrupt or stale (it is rebuilt, never used)."""


class SimulationError(StudyError):
    """A simulation failed (diverged, solver did not converge); no result is written."""
