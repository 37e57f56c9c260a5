"""exudyn_study: structural damping of flexible bodies in multibody models.

From FE meshes to Exudyn flexible bodies with a damping ratio per mode, the test rig
and its three model variants, experimental modal analysis (PolyMAX), damping
calibration, pseudo damage, and diagnosis of simulation/recording mismatch.

Subpackages and modules (see DESIGN in the README):

- ``fe``: Netgen geometry and NGsolve mass/stiffness matrices (the only ngsolve user)
- ``reduction``: Craig-Bampton reduction and orthogonalisation (Exudyn FEMinterface)
- ``damping``: modal damping functions (pure NumPy)
- ``identify``: FRF estimators, PolyMAX, LSFD, MAC (pure NumPy/SciPy)
- ``recording``: the recording type, HDF5 and UFF58 I/O (pure NumPy/h5py/pyuff)
- ``fatigue``, ``signals``: pseudo damage and drive signals (pure NumPy/SciPy)
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("exudyn_study")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
