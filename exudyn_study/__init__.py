"""exudyn_study: structural damping of flexible bodies in multibody models.

From FE meshes to Exudyn flexible bodies with a damping ratio per mode, the test rig
and its three model variants, experimental modal analysis (PolyMAX), damping
calibration, pseudo damage, and diagnosis of simulation/recording mismatch.

Subpackages (``docs/development.md`` has the table):

- ``infra``: the on-disk cache, atomic writes, BLAS threads
- ``recording``: the recording type, HDF5 and UFF58 files (``read_recording``, ``write_recording``)
- ``signals``: drive signals, relative pseudo damage, drive iteration
- ``identify``: FRF estimators, PolyMAX, mode selection, LSFD, MAC (neither exudyn nor ngsolve)
- ``bodies``: FE (``bodies.fe``, the only ngsolve user), Craig-Bampton reduction, damping functions,
  the Exudyn bodies (``flexible_body``)
- ``linear``: the linearised system, exact responses, system modes, mode pairing
- ``model``: the rig, the sensors and Models 1-3 (``build_model``, ``linearise``)
- ``simulate``: ``simulate`` a model into a recording
- ``physics``: the catalogue of left-out physics (``register``)
- ``calibrate``: damping calibration (``calibrate``)
- ``virtual_rig``: truth scenarios played through the servo and the acquisition chain
- ``diagnose``: ``diagnose_rig``, ``diagnose_generic``
- ``sweep``: parameter sweeps (``run_sweep``) and the damage grid
- ``cli``: the ``exudyn-study`` console script
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("exudyn_study")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
