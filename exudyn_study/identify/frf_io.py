"""Measured FRFs from files: UFF58 (function type 4) and an HDF5 FRF dataset.

Test software (Simcenter Testlab, Artemis, B&K) exchanges FRFs as universal-file dataset 58
records of function type 4: one record per response/reference pair, the pair named by the
response and reference node and direction records (``rsp_node``/``rsp_dir``,
``ref_node``/``ref_dir``), complex ordinates on an even frequency grid. Records of function type
6 (coherence) with the same pair give the coherence. :func:`read_frf_file` assembles them into an
:class:`~exudyn_study.identify.frf.FRF` ``H[n_out, n_in, n_freq]``.

Names: a response is called by its ``id1`` text when the file sets one, else
``<node>:<+/-><X|Y|Z>`` (e.g. ``12:+Z``); a reference always ``<node>:<+/-><X|Y|Z>``, the name
given to ``--reference``. The ordinates are kept in the file's units: identification does
not depend on the FRF's scale (shapes are normalised).

The HDF5 FRF format (:func:`write_frf_hdf5`) holds a group ``frf`` with the datasets
``freq_hz``, ``H`` (complex, ``[n_out, n_in, n_freq]``) and optionally ``coherence``, and the
attributes ``outputs``, ``inputs``, ``estimator``, ``n_averages``.

Files that cannot be identified are refused on one line naming the file and the fix: no
reference record, FRF records mixed with time data, FRFs on different frequency grids.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.frf import FRF

__all__ = ["is_frf_file", "read_frf_file", "write_frf_uff", "write_frf_hdf5", "FRF_FUNCTION_TYPES"]

#: UFF58 function types read as FRFs: 4 frequency response function, 5 transmissibility
FRF_FUNCTION_TYPES = (4, 5)
_COHERENCE = 6
_DIRS = {1: "X", 2: "Y", 3: "Z", 4: "RX", 5: "RY", 6: "RZ"}
_DIR_CODES = {"X": 1, "Y": 2, "Z": 3}


def _dof_name(node, direction) -> str:
    d = int(direction)
    return f"{int(node)}:{'-' if d < 0 else '+'}{_DIRS.get(abs(d), str(abs(d)))}"


def _uff_sets(path: Path):
    import pyuff

    from exudyn_study.recording.uff_ascii import read_sets

    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
        return read_sets(uff, path, types)
    except Exception as exc:  # pyuff raises plain Exception on malformed files
        raise InputError(f"FRF file {str(path)!r} is not a readable UFF file ({exc})") from exc


def is_frf_file(path: str | os.PathLike) -> bool:
    """Return whether ``path`` holds FRFs (UFF58 function type 4/5, or an HDF5 ``frf`` group).

    Parameters
    ----------
    path : str or path-like
        A ``.uff``/``.unv`` or ``.h5``/``.hdf5`` file.

    Returns
    -------
    bool
    """
    p = Path(path)
    if p.suffix.lower() in (".h5", ".hdf5"):
        import h5py

        try:
            with h5py.File(p, "r") as f:
                return "frf" in f
        except OSError:
            return False
    if p.suffix.lower() in (".uff", ".unv"):
        import pyuff

        try:
            uff = pyuff.UFF(str(p))
            types = [int(t) for t in uff.get_set_types()]
            return any(t == 58 and int(uff.read_sets(i, header_only=True).get("func_type", 0))
                       in FRF_FUNCTION_TYPES for i, t in enumerate(types))
        except Exception:  # pyuff raises plain Exception on malformed files; the reader reports it
            return False
    return False


def read_frf_file(path: str | os.PathLike) -> FRF:
    """Read measured FRFs (UFF58 function type 4/5 or the HDF5 FRF format).

    Parameters
    ----------
    path : str or path-like
        ``.uff``/``.unv`` or ``.h5``/``.hdf5`` file.

    Returns
    -------
    FRF
        ``H[n_out, n_in, n_freq]`` with names from the file, the coherence when the file has
        it (else ones), ``n_averages`` from the HDF5 file (1 for UFF, which does not carry it),
        no sample rate (no leakage model: the Welch settings of the export are unknown).

    Raises
    ------
    InputError
        For an unreadable file, a file without FRFs, an FRF without a reference record,
        FRFs mixed with time data, FRFs on different frequency grids, or a response/reference
        pair missing from the matrix.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"FRF file {str(p)!r} does not exist")
    if p.suffix.lower() in (".h5", ".hdf5"):
        return _read_hdf5(p)
    if p.suffix.lower() not in (".uff", ".unv"):
        raise InputError(f"FRF file {str(p)!r}: unknown suffix {p.suffix!r}; expected .uff/.unv "
                         "(UFF58) or .h5/.hdf5")
    return _read_uff(p)


def _read_uff(p: Path) -> FRF:
    where = f"FRF file {str(p)!r}"
    sets = [s for s in _uff_sets(p) if s["type"] == 58]
    kinds = {int(s.get("func_type", 0)) for s in sets}
    frf_sets = [s for s in sets if int(s.get("func_type", 0)) in FRF_FUNCTION_TYPES]
    if not frf_sets:
        raise InputError(f"{where} holds no FRF records (UFF58 function types {sorted(kinds) or 'none'}); "
                         "export FRFs as UFF58 function type 4")
    if 1 in kinds:
        raise InputError(f"{where} mixes FRF records (function type 4) with time data (type 1); "
                         "export FRFs and time histories into separate files")
    grids = {(int(s["num_pts"]), round(float(s["abscissa_min"]), 9), round(float(s["abscissa_inc"]), 12))
             for s in frf_sets}
    if len(grids) > 1:
        listing = "; ".join(f"{n} lines from {f0:g} Hz every {df:g} Hz" for n, f0, df in sorted(grids))
        raise InputError(f"{where}: the FRFs lie on different frequency grids ({listing}); export "
                         "them with one resolution and band")
    outputs: list[str] = []
    inputs: list[str] = []
    pairs = {}
    for s in frf_sets:
        if int(s.get("ref_node", 0)) == 0 and int(s.get("ref_dir", 0)) == 0:
            raise InputError(f"{where}: FRF {str(s.get('id1', '')).strip() or '?'!r} has no reference "
                             "record (reference node and direction 0); export the FRFs with their "
                             "reference DOF")
        ref = _dof_name(s["ref_node"], s["ref_dir"])
        rsp = str(s.get("id1", "")).strip()
        if not rsp or rsp.upper() == "NONE":
            rsp = _dof_name(s["rsp_node"], s["rsp_dir"])
        if rsp not in outputs:
            outputs.append(rsp)
        if ref not in inputs:
            inputs.append(ref)
        key = (_dof_name(s["rsp_node"], s["rsp_dir"]), ref)
        if (rsp, ref) in pairs:
            raise InputError(f"{where}: two FRF records for response {rsp!r} and reference {ref!r}; "
                             "keep one")
        pairs[(rsp, ref)] = (key, np.asarray(s["data"]))
    n, f0, df = next(iter(grids))
    coh_by_dof = {}
    for s in sets:
        if int(s.get("func_type", 0)) == _COHERENCE:
            key = (_dof_name(s["rsp_node"], s["rsp_dir"]), _dof_name(s["ref_node"], s["ref_dir"]))
            data = np.real(np.asarray(s["data"], dtype=complex))
            if data.shape == (n,):
                coh_by_dof[key] = data
    h = np.zeros((len(outputs), len(inputs), n), complex)
    coh = np.ones(h.shape)
    for i, rsp in enumerate(outputs):
        for j, ref in enumerate(inputs):
            if (rsp, ref) not in pairs:
                raise InputError(f"{where}: no FRF for response {rsp!r} and reference {ref!r}; export "
                                 "every response for every reference")
            key, data = pairs[(rsp, ref)]
            if not np.iscomplexobj(data):
                raise InputError(f"{where}: FRF {rsp!r}/{ref!r} holds real data; expected complex "
                                 "ordinates (UFF58 ordinate data type 5 or 6)")
            h[i, j] = data
            if key in coh_by_dof:
                coh[i, j] = np.clip(coh_by_dof[key], 0.0, 1.0)
    if not np.all(np.isfinite(h)):
        raise InputError(f"{where}: the FRFs hold NaN or infinite values; export finite data")
    freq = f0 + df * np.arange(n)
    return FRF(freq_hz=freq, H=h, coherence=coh, estimator="H1", resolution_hz=float(df),
               n_averages=1, outputs=tuple(outputs), inputs=tuple(inputs))


def _read_hdf5(p: Path) -> FRF:
    import h5py

    where = f"FRF file {str(p)!r}"
    try:
        with h5py.File(p, "r") as f:
            if "frf" not in f:
                raise InputError(f"{where} has no 'frf' group; write it with write_frf_hdf5 "
                                 "(a recording file holds time data: identify it as a recording)")
            g = f["frf"]
            freq = np.asarray(g["freq_hz"], float)
            h = np.asarray(g["H"])
            coh = np.asarray(g["coherence"], float) if "coherence" in g else np.ones(h.shape)
            outputs = tuple(str(x) for x in g.attrs.get("outputs", ()))
            inputs = tuple(str(x) for x in g.attrs.get("inputs", ()))
            estimator = str(g.attrs.get("estimator", "H1"))
            n_avg = int(g.attrs.get("n_averages", 1))
    except OSError as exc:
        raise InputError(f"{where} is not a readable HDF5 file ({exc})") from exc
    if h.ndim != 3 or h.shape[-1] != freq.size or coh.shape != h.shape:
        raise InputError(f"{where}: H of shape {h.shape}, coherence {coh.shape} and {freq.size} "
                         "frequencies: expected H[n_out, n_in, n_freq] and a coherence of the same shape")
    if not inputs or len(inputs) != h.shape[1]:
        raise InputError(f"{where}: {len(inputs)} reference names for {h.shape[1]} references; the "
                         "'inputs' attribute must name every reference")
    if len(outputs) != h.shape[0]:
        raise InputError(f"{where}: {len(outputs)} response names for {h.shape[0]} responses; "
                         "the 'outputs' attribute must name every response")
    steps = np.diff(freq)
    if freq.size < 2 or np.ptp(steps) > 1e-6 * np.abs(steps).max():
        raise InputError(f"{where}: the frequencies are not an even grid; resample the FRFs onto one")
    if not np.all(np.isfinite(h)):
        raise InputError(f"{where}: the FRFs hold NaN or infinite values; export finite data")
    return FRF(freq_hz=freq, H=h.astype(complex), coherence=np.clip(coh, 0, 1),
               estimator=estimator if estimator in ("H1", "H2", "Hv") else "H1",
               resolution_hz=float(np.median(steps)), n_averages=n_avg, outputs=outputs,
               inputs=inputs)


def write_frf_hdf5(frf: FRF, path: str | os.PathLike) -> Path:
    """Write ``frf`` in the HDF5 FRF format (atomically: a temporary file renamed).

    Parameters
    ----------
    frf : FRF
        FRFs with names.
    path : str or path-like
        ``.h5``/``.hdf5`` file to write.

    Returns
    -------
    Path
    """
    import h5py

    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        g = f.create_group("frf")
        g.create_dataset("freq_hz", data=frf.freq_hz)
        g.create_dataset("H", data=frf.H)
        g.create_dataset("coherence", data=frf.coherence)
        g.attrs["outputs"] = list(frf.outputs)
        g.attrs["inputs"] = list(frf.inputs)
        g.attrs["estimator"] = frf.estimator
        g.attrs["n_averages"] = int(frf.n_averages)
    os.replace(tmp, p)
    return p


def write_frf_uff(frf: FRF, path: str | os.PathLike, *, nodes_out, nodes_in,
                  coherence: bool = True) -> Path:
    """Write ``frf`` as UFF58 function-type-4 records (and type-6 coherence), atomically.

    Parameters
    ----------
    frf : FRF
        FRFs; the grid must start at ``freq_hz[0]`` with step ``resolution_hz``.
    path : str or path-like
        ``.uff`` file to write.
    nodes_out, nodes_in : sequence of (int, str)
        Node number and direction ('X', 'Y', 'Z', optionally signed '-Z') of every response
        and every reference.
    coherence : bool, optional
        Also write the coherence records (default True).

    Returns
    -------
    Path
    """
    import pyuff

    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    if tmp.exists():
        tmp.unlink()

    def code(d: str) -> int:
        return -_DIR_CODES[d[1:]] if d.startswith("-") else _DIR_CODES[d.lstrip("+")]

    uff = pyuff.UFF(str(tmp))
    sets = []
    for i, (rn, rd) in enumerate(nodes_out):
        for j, (fn, fd) in enumerate(nodes_in):
            for kind, data in ((4, frf.H[i, j]), (_COHERENCE, frf.coherence[i, j].astype(complex))):
                if kind == _COHERENCE and not coherence:
                    continue
                sets.append(pyuff.prepare_58(
                    binary=0, id1=frf.outputs[i] if frf.outputs else "NONE", id2="", id3="",
                    id4="", id5="", func_type=kind, rsp_node=int(rn), rsp_dir=code(rd),
                    ref_node=int(fn), ref_dir=code(fd), ord_data_type=6,
                    num_pts=frf.freq_hz.size, abscissa_spacing=1,
                    abscissa_min=float(frf.freq_hz[0]), abscissa_inc=float(frf.resolution_hz),
                    abscissa_spec_data_type=18, ordinate_spec_data_type=12,
                    orddenom_spec_data_type=13 if kind == 4 else 0, z_axis_spec_data_type=0,
                    data=np.asarray(data, complex), x=frf.freq_hz))
    uff.write_sets(sets, mode="overwrite")
    os.replace(tmp, p)
    return p
