"""Experimental modal analysis: FRF estimators, PolyMAX, automatic selection, LSFD, MAC.

Imports neither ngsolve nor exudyn. Layouts: FRFs ``H[n_out, n_in, n_freq]``, time
data ``x[n_channels, n_samples]``, shapes ``phi[n_dof, n_modes]``; SI units, Hz for
frequencies, damping as a ratio.

Typical use::

    from exudyn_study.recording import read_recording
    from exudyn_study.identify import identify_recording, write_modes_json

    result = identify_recording(read_recording("run.h5"), "ARFVZ", band_hz=(3, 50))
    write_modes_json(result.model, "modes.json")

Modules: :mod:`.frf` (H1/H2/Hv, coherence), :mod:`.polymax` (stabilisation),
:mod:`.selection` (automatic pole clustering), :mod:`.lsfd` (residues, shapes,
synthesis, pole refinement, leakage model), :mod:`.mac` (MAC, MPC),
:mod:`.resolution` (lines per half-power bandwidth, the automatic resolution),
:mod:`.frf_io` (measured FRFs: UFF58 function type 4, HDF5), :mod:`.model` (ModalModel and
its JSON), :mod:`.pipeline` (end to end), :mod:`.plots`, :mod:`.synthetic`.

``lsfd``, ``polymax`` and ``mac`` are at once modules and their main functions:
the package exports the modules, and calling one calls the function of the same
name (``identify.mac(phi_a, phi_b)``), while ``identify.lsfd.Leakage`` and
``import exudyn_study.identify.lsfd`` reach the module.
"""

# modules that are also their main function (callable): lsfd(...), polymax(...), mac(...)
from exudyn_study.identify import lsfd, mac, polymax
from exudyn_study.identify.frf import FRF, estimate_frf, frf_weights
from exudyn_study.identify.frf_io import is_frf_file, read_frf_file, write_frf_hdf5, write_frf_uff
from exudyn_study.identify.lsfd import Leakage, LSFDResult, fit_modal_model, refine_poles, synthesise
from exudyn_study.identify.mac import automac, mcf, mpc
from exudyn_study.identify.model import ModalModel, Mode, read_modes_json, write_modes_json
from exudyn_study.identify.pipeline import IdentificationResult, identify, identify_frf, identify_recording
from exudyn_study.identify.polymax import Poles, modal_to_pole, pole_to_modal
from exudyn_study.identify.resolution import lines_in_half_power, resolution_warnings, suggest_resolution
from exudyn_study.identify.selection import Selection, select_modes

__all__ = [
    "FRF",
    "estimate_frf",
    "frf_weights",
    "is_frf_file",
    "read_frf_file",
    "write_frf_hdf5",
    "write_frf_uff",
    "Poles",
    "polymax",
    "pole_to_modal",
    "modal_to_pole",
    "Selection",
    "select_modes",
    "Leakage",
    "LSFDResult",
    "lsfd",
    "refine_poles",
    "fit_modal_model",
    "synthesise",
    "mac",
    "automac",
    "mpc",
    "mcf",
    "lines_in_half_power",
    "suggest_resolution",
    "resolution_warnings",
    "Mode",
    "ModalModel",
    "read_modes_json",
    "write_modes_json",
    "IdentificationResult",
    "identify",
    "identify_frf",
    "identify_recording",
]
