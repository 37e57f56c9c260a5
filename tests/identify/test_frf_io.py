"""Measured FRFs from files (UFF58 function type 4, HDF5): read, identify end to end, refuse bad files."""

import numpy as np
import pytest

from exudyn_study.cli import main
from exudyn_study.errors import InputError
from exudyn_study.identify import read_modes_json
from exudyn_study.identify.frf import FRF
from exudyn_study.identify.frf_io import is_frf_file, read_frf_file, write_frf_hdf5, write_frf_uff
from exudyn_study.identify.polymax import modal_to_pole
from exudyn_study.identify.synthetic import pole_residue_frf

FREQ = np.array([12.0, 19.0, 19.3, 31.0])  # a close pair 1.6 % apart
ZETA = np.array([0.01, 0.005, 0.008, 0.05])  # and a 5 %-damped mode


def _frf(grid_step=0.05) -> FRF:
    """Exact FRFs of 4 modes on 8 responses, one reference (known poles)."""
    rng = np.random.default_rng(3)
    f = np.arange(40, 900) * grid_step
    res = (rng.standard_normal((8, 1, 4)) * 10).astype(complex)
    h = pole_residue_frf(modal_to_pole(FREQ, ZETA), res, f)
    return FRF(freq_hz=f, H=h, coherence=np.full(h.shape, 0.98), estimator="H1",
               resolution_hz=grid_step, n_averages=1, outputs=tuple(f"P{i}" for i in range(8)),
               inputs=("1:+Z",))


def _nodes():
    return [(i + 2, "XYZ"[i % 3]) for i in range(8)], [(1, "Z")]


def test_uff58_frf_round_trip_and_identified_end_to_end(tmp_path):
    frf = _frf()
    path = write_frf_uff(frf, tmp_path / "frf.uff", nodes_out=_nodes()[0], nodes_in=_nodes()[1])
    assert is_frf_file(path)
    back = read_frf_file(path)
    assert back.inputs == ("1:+Z",) and back.outputs == frf.outputs
    np.testing.assert_allclose(back.freq_hz, frf.freq_hz, rtol=1e-9)
    np.testing.assert_allclose(back.H, frf.H, rtol=1e-6, atol=1e-9 * np.abs(frf.H).max())
    np.testing.assert_allclose(back.coherence, 0.98, atol=1e-9)
    out = tmp_path / "modes.json"
    assert main(["identify", str(path), "--reference", "1:+Z", "--json", str(out)]) == 0
    model = read_modes_json(out)
    np.testing.assert_allclose(model.frequency_hz, FREQ, rtol=1e-4)
    np.testing.assert_allclose(model.damping_ratio, ZETA, rtol=1e-2)


def test_hdf5_frf_round_trip(tmp_path):
    frf = _frf()
    back = read_frf_file(write_frf_hdf5(frf, tmp_path / "frf.h5"))
    assert is_frf_file(tmp_path / "frf.h5")
    np.testing.assert_array_equal(back.H, frf.H)
    assert back.outputs == frf.outputs and back.inputs == frf.inputs


def _write_raw(path, records):
    import pyuff

    uff = pyuff.UFF(str(path))
    uff.write_sets([pyuff.prepare_58(
        binary=0, id1=r.get("id1", "P"), id2="", id3="", id4="", id5="", func_type=r["func_type"],
        rsp_node=r.get("rsp_node", 2), rsp_dir=3, ref_node=r.get("ref_node", 1),
        ref_dir=r.get("ref_dir", 3), ord_data_type=6 if r["func_type"] == 4 else 4,
        num_pts=r["data"].size, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=r.get("inc", 0.1),
        abscissa_spec_data_type=18 if r["func_type"] == 4 else 17, ordinate_spec_data_type=12,
        orddenom_spec_data_type=13, z_axis_spec_data_type=0, data=r["data"],
        x=np.arange(r["data"].size) * r.get("inc", 0.1)) for r in records], mode="overwrite")


@pytest.mark.parametrize("records, match", [
    ([{"func_type": 4, "ref_node": 0, "ref_dir": 0, "data": np.ones(64, complex)}],
     "has no reference record"),
    ([{"func_type": 4, "data": np.ones(64, complex)},
      {"func_type": 1, "id1": "T", "data": np.ones(64)}], "mixes FRF records"),
    ([{"func_type": 4, "data": np.ones(64, complex)},
      {"func_type": 4, "id1": "Q", "rsp_node": 3, "inc": 0.2, "data": np.ones(64, complex)}],
     "different frequency grids"),
])
def test_bad_frf_files_refused_on_one_line_and_nothing_written(tmp_path, capsys, records, match):
    path = tmp_path / "bad.uff"
    _write_raw(path, records)
    with pytest.raises(InputError, match=match):
        read_frf_file(path)
    out = tmp_path / "modes.json"
    assert main(["identify", str(path), "--reference", "1:+Z", "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and match in err[0]
    assert not out.exists()
