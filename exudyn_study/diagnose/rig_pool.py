"""Worker pool of the rig diagnosis: the residual evaluations of one fit on several processes.

A fit's finite-difference Jacobian is the diagnosis's independent work: one residual evaluation
per parameter, each a simulation of the candidate's system against the training recordings (about
one second on the thesis recordings). :class:`EvaluationPool` spreads them over a local process
pool (``workers``) or an existing Dask cluster (``scheduler``), as :func:`exudyn_study.sweep.run_sweep`
runs its points:

- local: :class:`concurrent.futures.ProcessPoolExecutor` with the ``spawn`` start method; BLAS
  limited to one thread per worker (so ``workers`` processes use ``workers`` cores); a worker ends
  when the diagnosis's process is gone;
- Dask: ``distributed.Client(scheduler)``; the workers need the package installed.

The evaluator (the recordings) and the candidate (its matrices) go to the workers once per fit,
not per evaluation: locally as a pickle file each worker reads once and keeps (written with
``cloudpickle``, installed with Dask, when it is there: candidate classes defined inside functions
need it; without it such a candidate's fit stays in the calling process), on Dask scattered to
every worker; a task sends only the parameter vector. The workers never build the model or load
the flexible bodies. :meth:`EvaluationPool.mapper` returns the map-like callable that
:func:`scipy.optimize.least_squares` takes as ``workers``: the points of a Jacobian are the points
the serial fit evaluates, and each evaluation is the same arithmetic in another process, so a fit
gives bit for bit the serial fit's result.

Package-internal API of :mod:`exudyn_study.diagnose`.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import pickle
import shutil
import tempfile
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.infra.workers import die_with_parent, single_threaded_workers

__all__ = ["EvaluationPool", "evaluation_pool"]

log = logging.getLogger(__name__)

#: evaluators the pool keeps sent (the diagnosis's training, spectral and shorter-record ones, ...)
EVALUATORS_KEPT = 4
#: contexts (evaluators, candidates) a local worker keeps loaded
WORKER_MEMO = EVALUATORS_KEPT + 1

_memo: dict = {}  # in a worker: context path -> object (at most WORKER_MEMO)


class NotSendable(Exception):
    """An object the local workers cannot receive (it holds something pickle cannot write)."""


class EvaluationPool:
    """Residual evaluations on a local process pool or a Dask cluster (see the module docstring).

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default 1: no pool, every evaluation in the calling process);
        ignored with ``scheduler``.
    scheduler : str or None, optional
        Address of a running Dask scheduler (``tcp://host:port``); None: local processes.

    Raises
    ------
    InputError
        ``workers`` not an integer >= 1, a malformed or unreachable scheduler, or Dask not installed.
    """

    def __init__(self, workers: int = 1, scheduler: str | None = None):
        if scheduler is None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
            raise InputError(f"workers = {workers!r}: expected an integer >= 1 (local worker processes)")
        self.workers = int(workers) if scheduler is None else None
        self.scheduler = None
        self._executor = None
        self._client = None
        self._dir = None
        self._contexts: dict = {}  # key -> (object sent, its file path or Dask future)
        self._count = itertools.count()
        self.evaluations = 0  # residual evaluations the workers made
        if scheduler is not None:
            from exudyn_study.sweep.config import check_scheduler

            self.scheduler = check_scheduler(scheduler)
            try:
                from distributed import Client
            except ImportError:
                raise InputError(
                    "--scheduler needs dask.distributed; install it with pip install 'dask[distributed]'"
                ) from None
            self._client = Client(self.scheduler, timeout="10s")

    @property
    def parallel(self) -> bool:
        """Whether evaluations run outside the calling process."""
        return self._client is not None or (self.workers or 1) > 1

    def describe(self) -> str:
        """Return where the evaluations run, for the progress text and the result's metadata."""
        if self._client is not None:
            return f"Dask at {self.scheduler}"
        return f"{self.workers} local worker process(es)" if self.parallel else "the calling process"


    def mapper(self, h, ev, channels, penalty: tuple):
        """Return a map-like callable evaluating ``h``'s residual on ``ev`` in the workers (None: serially).

        The callable, ``m(fun, xs)``, returns the residual vectors at the fitting variables ``xs``
        (:func:`~exudyn_study.diagnose.rig_hypotheses.to_params` of ``h``), ``penalty`` where the
        candidate's system cannot be simulated; that is what ``fun`` (the serial fit's function)
        gives, which is not sent. None when the pool is serial or the candidate or evaluator cannot
        be sent (a candidate holding a local function): the fit then runs in this process.

        Parameters
        ----------
        h : Hypothesis
            The candidate.
        ev : Evaluator or SpectralEvaluator or DistortionEvaluator
            Gives the residual vector of a system.
        channels : sequence of str
            The simulated channels, in row order.
        penalty : tuple
            ``(n_rows, value)``: the residual of a parameter set whose system cannot be simulated is
            ``value`` in each of its ``n_rows`` rows.

        Returns
        -------
        callable or None
            ``m(fun, xs) -> list of numpy.ndarray``, or None.
        """
        if not self.parallel:
            return None
        try:
            ev_ref = self._context(("ev", id(ev), getattr(ev, "version", 0)), ev)
            # a candidate is sent for each fit (between fits its output gains or start may change)
            h_ref = self._context(("h", next(self._count)), h)
        except NotSendable as exc:
            log.debug("evaluations of %s stay serial: %s", getattr(h, "label", h), exc)
            return None
        header = (tuple(channels), int(penalty[0]), float(penalty[1]))

        def m(fun, xs):  # noqa: ARG001 - the workers evaluate what ``fun`` would
            xs = [np.array(x, dtype=float) for x in xs]
            self.evaluations += len(xs)
            return self._map(ev_ref, h_ref, header, xs)

        return m

    def map_shared(self, fn, shared, items) -> list:
        """Return ``[fn(shared, item) for item in items]``, evaluated in the workers.

        ``shared`` goes to the workers once (as an evaluator does); ``fn`` must be a module-level
        function. Serially (or when ``shared`` cannot be sent) in this process.

        Parameters
        ----------
        fn : callable
            ``fn(shared, item)``, importable by the workers.
        shared : object
            What every call needs.
        items : list
            One call each.

        Returns
        -------
        list
            The results, in the order of ``items``.
        """
        if not self.parallel:
            return [fn(shared, item) for item in items]
        try:
            ref = self._context(("shared", next(self._count)), shared)
        except NotSendable as exc:
            log.debug("%s stays serial: %s", getattr(fn, "__name__", fn), exc)
            return [fn(shared, item) for item in items]
        try:
            if self._client is not None:
                futures = [self._client.submit(shared_task, fn, ref, item, pure=False) for item in items]
                return self._client.gather(futures)
            n = len(items)
            return list(self._local().map(shared_task, [fn] * n, [ref] * n, items))
        finally:  # sent for this map only
            for key in [k for k in self._contexts if k[0] == "shared"]:
                self._drop(key)

    def _context(self, key, obj):
        """Send ``obj`` to the workers once; its reference (a file path or a Dask future).

        The pool holds the objects it sent (so that the identity in an evaluator's ``key`` names no
        other object while it is kept): the last candidate, and the last :data:`EVALUATORS_KEPT`
        evaluators.
        """
        if key in self._contexts and self._contexts[key][0] is obj:
            return self._contexts[key][1]
        if key in self._contexts:
            self._drop(key)
        kind = key[0]
        same_kind = [k for k in self._contexts if k[0] == kind]
        if kind == "ev":  # an evaluator whose state changed: its older state goes
            same_kind = [k for k in same_kind if k[1] == key[1]] + same_kind[: -EVALUATORS_KEPT + 1]
        for k in dict.fromkeys(same_kind):
            self._drop(k)
        if self._client is not None:
            ref = self._client.scatter(obj, broadcast=True, hash=False)
        else:
            try:  # cloudpickle (installed with Dask) writes classes defined in functions, pickle cannot
                import cloudpickle as writer
            except ImportError:
                writer = pickle
            try:
                data = writer.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
            except (pickle.PicklingError, TypeError, AttributeError) as exc:  # e.g. a lock in it
                raise NotSendable(str(exc)) from None
            if self._dir is None:
                self._dir = Path(tempfile.mkdtemp(prefix="exudyn_study_pool_"))
            ref = str(self._dir / f"{kind}-{next(self._count)}.pkl")
            with open(ref, "wb") as f:
                f.write(data)
        self._contexts[key] = (obj, ref)
        return ref

    def _drop(self, key) -> None:
        _, ref = self._contexts.pop(key)
        if self._client is None:
            with contextlib.suppress(OSError):
                os.remove(ref)
        else:
            ref.release()

    def _map(self, ev_ref, h_ref, header, xs) -> list:
        if self._client is not None:
            futures = [
                self._client.submit(evaluate_task, ev_ref, h_ref, header, x, pure=False) for x in xs
            ]
            return self._client.gather(futures)
        executor = self._local()
        n = len(xs)
        return list(executor.map(evaluate_task, [ev_ref] * n, [h_ref] * n, [header] * n, xs))

    def _local(self):
        if self._executor is None:
            from concurrent.futures import ProcessPoolExecutor
            from multiprocessing import get_context

            with single_threaded_workers():
                self._executor = ProcessPoolExecutor(
                    max_workers=self.workers,
                    mp_context=get_context("spawn"),
                    initializer=die_with_parent,
                    initargs=(os.getpid(),),
                )
                # the workers start now, with the environment above
                list(self._executor.map(_ready, range(self.workers)))
        return self._executor

    def close(self) -> None:
        """Stop the workers and remove the sent contexts."""
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None
        if self._client is not None:
            for key in list(self._contexts):
                self._drop(key)
            self._client.close()
            self._client = None
        self._contexts = {}
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


@contextlib.contextmanager
def evaluation_pool(workers: int = 1, scheduler: str | None = None):
    """Yield an :class:`EvaluationPool` that is closed on exit.

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default 1: serial).
    scheduler : str or None, optional
        Dask scheduler address (None: local).

    Yields
    ------
    EvaluationPool
    """
    pool = EvaluationPool(workers, scheduler)
    try:
        yield pool
    finally:
        pool.close()


def _load(ref):
    """Return the object behind a context reference (a worker keeps the last :data:`WORKER_MEMO` read)."""
    if not isinstance(ref, str):
        return ref  # Dask hands the scattered object itself
    if ref not in _memo:
        while len(_memo) >= WORKER_MEMO:
            _memo.pop(next(iter(_memo)))
        with open(ref, "rb") as f:
            _memo[ref] = pickle.load(f)
    return _memo[ref]


def evaluate_task(ev_ref, h_ref, header, x) -> np.ndarray:
    """Evaluate a candidate's residual in a worker (what the fit's function gives at ``x``).

    Parameters
    ----------
    ev_ref, h_ref : str or object
        The evaluator and the candidate: pickle files (local workers) or the objects (Dask).
    header : tuple
        ``(channels, n_rows, value)``: the simulated channels; a parameter set that cannot be
        simulated gives ``value`` in each of ``n_rows`` rows.
    x : numpy.ndarray
        The fitting variables, shape (n_params,).

    Returns
    -------
    numpy.ndarray
        The residual vector, shape (n_rows,).
    """
    from exudyn_study.diagnose.rig_evaluate import safe_residual
    from exudyn_study.diagnose.rig_hypotheses import to_params
    from exudyn_study.infra.blas import single_threaded_blas

    ev, h = _load(ev_ref), _load(h_ref)
    channels, n_rows, value = header
    with single_threaded_blas():
        r = safe_residual(h, ev, channels, to_params(h, x))
    return np.full(n_rows, value) if r is None else r


def shared_task(fn, ref, item):
    """``fn(shared, item)`` in a worker, ``shared`` behind its context reference.

    Parameters
    ----------
    fn : callable
        A module-level function.
    ref : str or object
        The shared object's pickle file (local workers) or the object (Dask).
    item : object
        This call's argument.

    Returns
    -------
    object
        What ``fn`` returns.
    """
    return fn(_load(ref), item)


def _ready(_) -> int:
    return os.getpid()


