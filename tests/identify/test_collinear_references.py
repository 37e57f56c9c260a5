"""Two references that move together are flagged; independent ones are not."""

import numpy as np
import scipy.signal as sps

from exudyn_study.identify.frf import estimate_frf
from exudyn_study.identify.pipeline import collinear_references_warning

RATE_HZ = 256.0


def _records(coupling: float, seed=0, seconds=120.0):
    rng = np.random.default_rng(seed)
    n = int(seconds * RATE_HZ)
    drive = rng.standard_normal(n)
    other = rng.standard_normal(n)
    ref_a = drive
    ref_b = coupling * drive + np.sqrt(1 - coupling**2) * other
    wn, zeta = 2 * np.pi * 20.0, 0.02
    b, a = sps.cont2discrete(([wn**2], [1, 2 * zeta * wn, wn**2]), 1 / RATE_HZ)[:2]
    resp = sps.lfilter(np.ravel(b), a, drive)[None] + 0.01 * rng.standard_normal((1, n))
    return np.vstack([ref_a, ref_b]), resp


def test_references_from_one_drive_are_flagged_with_their_names():
    refs, resp = _records(coupling=1.0)
    refs[1] = 0.998 * refs[1] + 1e-3 * np.random.default_rng(5).standard_normal(refs.shape[1])
    frf = estimate_frf(refs, resp, RATE_HZ, resolution_hz=0.5, estimator="H1")
    msg = collinear_references_warning(refs, RATE_HZ, frf, (5.0, 50.0), names=("ARFVZ", "ARFHZ"))
    assert msg is not None and "ARFVZ and ARFHZ" in msg and "separately" in msg


def test_partly_coherent_or_single_references_are_not_flagged():
    refs, resp = _records(coupling=0.9)  # coherence 0.81
    frf = estimate_frf(refs, resp, RATE_HZ, resolution_hz=0.5, estimator="H1")
    assert collinear_references_warning(refs, RATE_HZ, frf, (5.0, 50.0)) is None
    frf1 = estimate_frf(refs[:1], resp, RATE_HZ, resolution_hz=0.5, estimator="H1")
    assert collinear_references_warning(refs[:1], RATE_HZ, frf1, (5.0, 50.0)) is None
