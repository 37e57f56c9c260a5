"""Line weights of the FRF fit (inverse standard error) and module access."""

import importlib
import inspect

import numpy as np
import pytest

import exudyn_study.identify as ident
from exudyn_study.errors import InputError
from exudyn_study.identify import FRF, frf_weights, lsfd, refine_poles
from exudyn_study.identify.synthetic import table1_system


def test_frf_weights_are_the_inverse_standard_error():
    # Bendat & Piersol eq. 9.90: eps = sqrt(1 - coh) / (sqrt(coh) sqrt(2 n_d))
    h = np.array([[[2.0, 1j, 0.5]]])
    coh = np.array([[[0.99, 0.5, 0.9]]])
    frf = FRF(np.array([1.0, 2.0, 3.0]), h, coh, "H1", 1.0, 8)
    eps = np.sqrt((1 - coh) / (coh * 16))
    np.testing.assert_allclose(frf_weights(frf), 1 / (eps * np.abs(h)))


def test_weighted_fit_of_exact_frfs_is_exact():
    # any positive line weights leave an exact model exact (no bias from weighting)
    sysm = table1_system(n_channels=8)
    f = np.arange(0, 60.0001, 0.2)
    h = sysm.transmissibility(f)
    w = np.random.default_rng(0).uniform(0.5, 2.0, h.shape)
    start = sysm.poles * (1 + 2e-3) - 0.05
    p = refine_poles(h, f, start, band_hz=(3, 55), weights=w)
    np.testing.assert_allclose(p, sysm.poles, rtol=1e-7)
    r = lsfd(h, f, sysm.poles, band_hz=(3, 55), weights=w)
    np.testing.assert_allclose(r.residues, sysm.residues(), rtol=1e-7, atol=1e-9)
    with pytest.raises(InputError, match="weights of shape"):
        lsfd(h, f, sysm.poles, weights=w[:, :, :5])


@pytest.mark.parametrize("name", ["lsfd", "polymax", "mac"])
def test_modules_and_functions_of_the_same_name(name):
    mod = importlib.import_module(f"exudyn_study.identify.{name}")
    exported = getattr(ident, name)
    assert exported is mod  # `import exudyn_study.identify.lsfd` is the module ...
    func = vars(mod)[name]
    assert inspect.signature(exported) == inspect.signature(func)  # ... and calls its function
    assert exported.__all__  # module attributes reachable (e.g. lsfd.Leakage)


def test_calling_the_module_calls_the_function():
    from exudyn_study.identify import mac
    from exudyn_study.identify.lsfd import Leakage

    np.testing.assert_allclose(mac(np.eye(3), np.eye(3)), np.eye(3))
    assert ident.lsfd.Leakage is Leakage


def test_pole_at_the_band_edge_is_rejected():
    # a mode 0.1 Hz inside the band edge (half a line at 0.2 Hz) cannot be told from
    # edge effects: reason 'edge'; the same mode well inside the band is accepted
    from exudyn_study.identify import modal_to_pole, polymax, select_modes
    from exudyn_study.identify.synthetic import pole_residue_frf

    f = np.arange(0, 60.0001, 0.2)
    poles = modal_to_pole(np.array([10.1, 30.0]), np.array([0.01, 0.02]))
    rng = np.random.default_rng(1)
    res = (rng.standard_normal((6, 1, 2)) + 1j * rng.standard_normal((6, 1, 2))) * 50
    h = pole_residue_frf(poles, res, f)
    p = polymax(h, f, range(2, 21), band_hz=(10.0, 50.0))
    assert p.resolution_hz == pytest.approx(0.2)
    sel = select_modes(p)
    assert [round(c.frequency_hz, 1) for c in sel.modes] == [30.0]
    assert any(c.reason == "edge" and abs(c.frequency_hz - 10.1) < 0.05 for c in sel.clusters)
    sel2 = select_modes(polymax(h, f, range(2, 21), band_hz=(8.0, 50.0)))
    assert [round(c.frequency_hz, 1) for c in sel2.modes] == [10.1, 30.0]
