"""Progress of long steps on stderr: a tqdm bar over named stages that keeps its clock running.

A stage such as a sparse factorisation or an eigen-solve blocks for minutes without a chance to
update a bar; :class:`StageProgress` refreshes its bar from a small background thread once a
second, so the elapsed time keeps moving and the user sees the step is alive. The bar is off when
stderr is not a terminal (tests, CI, logs) unless ``EXUDYN_STUDY_PROGRESS=1``, and always off with
``EXUDYN_STUDY_PROGRESS=0`` (the CLI's ``--quiet``). :class:`StatusProgress` does the same for a
step whose stages are not known in advance (a diagnosis's rounds and candidate fits): it shows the
elapsed time and the latest status text. :func:`write_line` prints a whole line to stderr without
tearing an active bar; :func:`keep_alive` gives any tqdm bar (a sweep's points) the same running clock.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from tqdm import tqdm

__all__ = ["StageProgress", "StatusProgress", "keep_alive", "progress_disabled", "write_line"]

#: seconds between refreshes of a bar whose stage is blocking
REFRESH_S = 1.0


def progress_disabled() -> bool | None:
    """Return whether progress bars are off, as tqdm's ``disable`` argument (None: tqdm decides).

    ``EXUDYN_STUDY_PROGRESS=0`` turns bars off, ``EXUDYN_STUDY_PROGRESS=1`` on even when stderr
    is not a terminal.

    Returns
    -------
    bool or None
        Passed to ``tqdm(disable=...)``: True disables, None lets tqdm decide by the terminal.
    """
    setting = os.environ.get("EXUDYN_STUDY_PROGRESS", "").strip()
    if setting == "0":
        return True
    if setting == "1":
        return False
    return None


class _RefreshedBar:
    """A tqdm bar on stderr redrawn once a second by a thread, so its clock runs while a step blocks."""

    def __init__(self, description: str, leave: bool, **bar_options):
        self._bar = tqdm(desc=description, file=sys.stderr, disable=progress_disabled(), leave=leave,
                         **bar_options)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __enter__(self):
        if not self._bar.disable:
            self._thread = threading.Thread(target=self._heartbeat, daemon=True)
            self._thread.start()
        return self

    def _heartbeat(self) -> None:
        while not self._stop.wait(REFRESH_S):
            self._bar.refresh()

    def _stop_heartbeat(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()


class StageProgress(_RefreshedBar):
    """A progress bar over named stages, refreshed once a second while a stage blocks.

    Parameters
    ----------
    description : str
        What is being done (the bar's label), e.g. ``"flexible body chassis"``.
    stages : sequence of str
        The stages in order; :meth:`stage` names the current one.
    leave : bool
        Keep the finished bar on the terminal (False: it disappears, for steps run many times).

    Examples
    --------
    >>> with StageProgress("body", ["mesh", "reduce"]) as p:   # doctest: +SKIP
    ...     p.stage("mesh"); mesh()
    ...     p.stage("reduce"); reduce()
    """

    def __init__(self, description: str, stages: Sequence[str], leave: bool = True):
        self.stages = tuple(stages)
        super().__init__(description, leave, total=len(self.stages),
                         bar_format="{desc} [{elapsed}] stage {n_fmt}/{total_fmt}{postfix}")

    def stage(self, name: str) -> None:
        """Mark the stages before ``name`` as done and show ``name`` as the current one.

        Parameters
        ----------
        name : str
            One of the stages given to the constructor.
        """
        index = self.stages.index(name)
        if index > self._bar.n:
            self._bar.update(index - self._bar.n)
        self._bar.set_postfix_str(name, refresh=True)

    def __exit__(self, exc_type, exc, tb) -> None:
        self._stop_heartbeat()
        if exc_type is None:
            self._bar.update(len(self.stages) - self._bar.n)
            self._bar.set_postfix_str("done", refresh=True)
        self._bar.close()


class StatusProgress(_RefreshedBar):
    """A bar with the elapsed time and the latest status text, refreshed once a second.

    For a step whose stages are not known in advance: calling the object with a text shows it as
    the current status (it is a ``progress(text)`` callable, as the diagnoses take).

    Parameters
    ----------
    description : str
        What is being done (the bar's label), e.g. ``"diagnosis of Model 3"``.
    leave : bool
        Keep the finished bar on the terminal.

    Examples
    --------
    >>> with StatusProgress("diagnosis") as status:   # doctest: +SKIP
    ...     status("comparing"); compare()
    ...     status("fitting joint_stiffness"); fit()
    """

    def __init__(self, description: str, leave: bool = True):
        super().__init__(description, leave, total=None, bar_format="{desc} [{elapsed}]{postfix}")

    def __call__(self, text: str) -> None:
        """Show ``text`` as the current status (its first line, at most 80 characters).

        Parameters
        ----------
        text : str
            What the step is doing now.
        """
        line = str(text).strip().splitlines()[0] if str(text).strip() else ""
        self._bar.set_postfix_str(line if len(line) <= 80 else line[:77] + "...", refresh=True)

    def __exit__(self, exc_type, exc, tb) -> None:
        self._stop_heartbeat()
        if exc_type is None:
            self._bar.set_postfix_str("done", refresh=True)
        self._bar.close()


def write_line(text: str) -> None:
    """Print ``text`` as a line on stderr, above any active progress bar (which is redrawn below it).

    Parameters
    ----------
    text : str
        The line.
    """
    tqdm.write(str(text), file=sys.stderr)


@contextmanager
def keep_alive(bar) -> Iterator:
    """Refresh the tqdm ``bar`` once a second while the ``with`` body runs, so its clock keeps moving.

    A bar over slow items (a sweep point of minutes) otherwise stands still between two updates.

    Parameters
    ----------
    bar : tqdm.tqdm
        The bar (a disabled bar is left alone).

    Yields
    ------
    tqdm.tqdm
        The same bar.
    """
    stop = threading.Event()
    thread = None
    if not getattr(bar, "disable", True):
        def beat() -> None:
            while not stop.wait(REFRESH_S):
                bar.refresh()

        thread = threading.Thread(target=beat, daemon=True)
        thread.start()
    try:
        yield bar
    finally:
        stop.set()
        if thread is not None:
            thread.join()
