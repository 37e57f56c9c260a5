"""The NumPy parser of ASCII UFF58 ordinates gives what pyuff's own parser gives."""

import numpy as np
import pytest
import pyuff

from exudyn_study.recording.uff_ascii import read_sets


@pytest.mark.parametrize("ord_type", [2, 4, 5, 6])  # single/double precision, real/complex
def test_ascii_58_ordinates_equal_pyuff(tmp_path, ord_type):
    rng = np.random.default_rng(ord_type)
    path = tmp_path / "a.uff"
    sets = []
    for k, n in enumerate((1001, 7, 4)):  # full and partial last lines
        data = rng.standard_normal(n) * 10.0 ** rng.integers(-5, 5, n)
        if ord_type in (5, 6):
            data = data + 1j * rng.standard_normal(n)
        sets.append(pyuff.prepare_58(
            binary=0, id1=f"c{k}", id2="", id3="", id4="", id5="", func_type=1 if ord_type in (2, 4) else 4,
            rsp_node=k + 1, rsp_dir=3, ref_node=int(ord_type in (5, 6)), ref_dir=3 * int(ord_type in (5, 6)),
            ord_data_type=ord_type, num_pts=n, abscissa_spacing=1, abscissa_min=0.5, abscissa_inc=1e-3,
            abscissa_spec_data_type=17, ordinate_spec_data_type=12, orddenom_spec_data_type=0,
            z_axis_spec_data_type=0, data=data, x=0.5 + 1e-3 * np.arange(n)))
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    uff = pyuff.UFF(str(path))
    types = [int(t) for t in uff.get_set_types()]
    full_reads = []

    class Counting:  # pyuff.UFF that records the datasets it parses in full
        def read_sets(self, i, header_only=False):
            if not header_only:
                full_reads.append(i)
            return uff.read_sets(i, header_only=header_only)

    ours = read_sets(Counting(), path, types)
    assert full_reads == []  # every ordinate parsed by NumPy, none by pyuff
    ref = [uff.read_sets(i) for i in range(len(types))]
    for a, b in zip(ours, ref, strict=True):
        assert a["data"].dtype == b["data"].dtype and a["data"].shape == b["data"].shape
        np.testing.assert_array_equal(a["data"], b["data"])
        np.testing.assert_allclose(a["x"], b["x"], rtol=1e-12)
        assert {k: v for k, v in a.items() if k not in ("data", "x")} == \
            {k: v for k, v in b.items() if k not in ("data", "x")}
