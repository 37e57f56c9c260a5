"""CSV/TSV import through a column map: units to SI, the drive's role, and one-line errors on bad files."""

from __future__ import annotations

import numpy as np
import pytest

from exudyn_study.cli import main
from exudyn_study.errors import InputError
from exudyn_study.recording import read_recording
from exudyn_study.recording.csv import CsvColumn, parse_column, read_csv

G = 9.80665


def _write(path, header, rows, sep=","):
    lines = [sep.join(header)] + [sep.join(str(v) for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def table(tmp_path):
    t = np.arange(40) / 400.0
    rows = [(ti, np.sin(30 * ti), 0.01 * np.cos(30 * ti), 2.0 * ti) for ti in t]
    return _write(tmp_path / "run.csv", ["t", "Fz", "a1", "d_mm"], rows), np.array(rows)


def test_column_map_converts_to_si_and_marks_the_drive(table):
    path, rows = table
    cols = [
        CsvColumn("force", "Fz", "force", "N", role="drive"),
        CsvColumn("DP", "a1", "acceleration", "g"),
        CsvColumn("x", 3, "displacement", "mm"),
    ]
    rec = read_csv(path, cols, time_column="t")
    assert rec.channels[0].sample_rate_hz == pytest.approx(400.0)
    assert rec.drive.name == "force" and rec.drive.unit == "N"
    np.testing.assert_allclose(rec.channel("DP").data, rows[:, 2] * G)  # g -> m/s^2
    np.testing.assert_allclose(rec.channel("x").data, rows[:, 3] * 1e-3)  # mm -> m


def test_tsv_and_semicolon_csv_give_the_same_recording(tmp_path):
    rows = [(i, 0.5 * i, -i) for i in range(10)]
    a = _write(tmp_path / "a.tsv", ["i", "F", "acc"], rows, sep="\t")
    b = _write(tmp_path / "b.csv", ["i", "F", "acc"], rows, sep=";")
    cols = [CsvColumn("F", "F", "force", "N", role="drive"), CsvColumn("acc", "acc", "acceleration", "m/s^2")]
    ra, rb = read_csv(a, cols, sample_rate_hz=100.0), read_csv(b, cols, sample_rate_hz=100.0)
    np.testing.assert_array_equal(ra.channel("acc").data, rb.channel("acc").data)


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("t,Fz,a1\n0,1,2\n0.0025,1,2\n", "column 'a9' is missing"),
        ("t,Fz,a1\n0,1,2\n0.0025,x,2\n", "line 3: channel 'force' .* 'x' is not a number"),
        ("t,Fz,a1\n0,1,2\n0.0025,1\n", "line 3: 2 values, the first row has 3"),
    ],
)
def test_bad_files_name_the_input_and_the_fix(tmp_path, content, match):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    cols = [
        CsvColumn("force", "Fz", "force", "N", role="drive"),
        CsvColumn("DP", "a9" if "missing" in match else "a1", "acceleration", "g"),
    ]
    with pytest.raises(InputError, match=match):
        read_csv(path, cols, sample_rate_hz=400.0)


def test_column_map_entries_are_checked():
    with pytest.raises(InputError, match="unit 'g' for force"):
        CsvColumn("F", "F", "force", "g")
    with pytest.raises(InputError, match="expected NAME=COLUMN:QUANTITY:UNIT"):
        parse_column("F:force:N")
    c = parse_column("force=2:force:kN:Z:drive")
    assert (c.column, c.unit, c.role) == (2, "kN", "drive")


def test_cli_import_writes_a_recording_and_writes_nothing_on_bad_input(table, tmp_path, capsys):
    path, _ = table
    out = tmp_path / "run.h5"
    args = [
        "import",
        str(path),
        "--time-column",
        "t",
        "--column",
        "force=Fz:force:N:Z:drive",
        "--column",
        "DP=a1:acceleration:g",
        "--position",
        "force=0.1,0,0",
        "--position",
        "DP=0.1,0,0",
        "--out",
        str(out),
    ]
    assert main(args) == 0
    rec = read_recording(out)
    assert rec.drive.position_m == rec.channel("DP").position_m == (0.1, 0.0, 0.0)
    bad = tmp_path / "bad.h5"
    assert (
        main(
            [
                "import",
                str(path),
                "--rate",
                "400",
                "--column",
                "force=Fx:force:N:Z:drive",
                "--column",
                "DP=a1:acceleration:g",
                "--out",
                str(bad),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "column 'Fx' is missing" in err[0]
    assert not bad.exists()
