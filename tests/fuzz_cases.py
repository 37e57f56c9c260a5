"""Generated bad inputs for every subcommand, by defect class, and the checks every case must pass.

Used by ``tests/test_fuzz.py`` (in-process, default run) and ``benchmarks/bench_fuzz.py``
(every case also in a fresh process, the figures by class). A case passes when the command
exits with code 2, prints exactly one line on stderr and no traceback, leaves no new file or
directory in the work directory, and every file there (the inputs) is byte-identical
afterwards.

The classes follow the reliability issue:

1. ``output-is-input``: an output path naming an input (same path, another spelling, a link);
2. ``reader-error``: malformed HDF5/UFF content (missing groups and attributes, text numbers);
3. ``corrupt-file``: a file cut short, bytes changed, absurd sample values;
4. ``unwritable-output``: an output naming a directory, below a file, on a read-only file system;
5. ``partial-output``: several outputs of which a late one is bad (nothing may be left);
6. ``absurd-value``: numeric options out of range, huge integers, NaN;
7. ``malformed-config``: bad JSON/TOML (types, NaN, huge integers, deep nesting, not UTF-8);
8. ``cache``: a cache directory that is a file or below one;
9. ``sweep``: sweep options (workers, scheduler, output) and huge point counts;
10. ``security``: a sweep name that is a path, ``[study] imports`` without the opt-in.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

CLASSES = (
    "output-is-input",
    "reader-error",
    "corrupt-file",
    "unwritable-output",
    "partial-output",
    "absurd-value",
    "malformed-config",
    "cache",
    "sweep",
    "security",
)

#: a directory no one can create files in, root included (a read-only file system)
READ_ONLY_DIR = "/proc"
#: longest a bad-input case may run in process (s): every check comes before any computation
CASE_TIMEOUT_S = 60


@dataclass(frozen=True)
class Case:
    """One bad command line: its defect class, the subcommand and the arguments (relative to the work dir)."""

    klass: str
    command: str
    name: str
    argv: tuple[str, ...]


@dataclass(frozen=True)
class Outcome:
    """What one case did, and whether it was handled cleanly."""

    case: Case
    code: int | None
    stderr: str
    new_paths: tuple[str, ...]
    changed: tuple[str, ...]
    exception: str
    wall_s: float

    @property
    def problems(self) -> list[str]:
        """Return what went wrong (empty: handled cleanly)."""
        out = []
        if self.exception:
            out.append(f"raised {self.exception}")
        if self.code != 2:
            out.append(f"exit code {self.code}")
        lines = [ln for ln in self.stderr.splitlines() if ln.strip()]
        if len(lines) != 1:
            out.append(f"{len(lines)} stderr lines")
        if "Traceback" in self.stderr:
            out.append("traceback")
        if self.new_paths:
            out.append(f"left {list(self.new_paths)[:3]}")
        if self.changed:
            out.append(f"changed {list(self.changed)[:3]}")
        return out

    @property
    def ok(self) -> bool:
        """Return True when the case was handled cleanly."""
        return not self.problems


# ----------------------------------------------------------------------------- fixture files


def _recording():
    from exudyn_study.identify.synthetic import simulate, table1_system, to_recording
    from exudyn_study.recording.types import Channel, Recording

    system = table1_system(n_channels=6, seed=1)
    reference, responses = simulate(system, 12.0, seed=1)
    rec = to_recording(system, reference, responses, metadata={"source": "fuzz"})
    drive = Channel(
        "drive",
        "displacement",
        "m",
        "Z",
        None,
        204.8,
        1e-3 * np.sin(np.arange(2458) / 204.8 * 2 * np.pi * 5.0),
        role="drive",
    )
    return Recording((*rec.channels, drive), dict(rec.metadata))


def _h5_variant(src: Path, dst: Path, edit) -> None:
    import h5py

    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as f:
        edit(f)


def _first_dataset(f):
    return f["channels"][sorted(f["channels"].keys())[0]]


def _bad_recordings(work: Path, good_h5: Path, good_uff: Path) -> dict[str, tuple[str, str]]:
    """Write the bad recordings; return name -> (class, file name)."""
    out: dict[str, tuple[str, str]] = {}

    def h5(name, klass, edit):
        _h5_variant(good_h5, work / f"{name}.h5", edit)
        out[name] = (klass, f"{name}.h5")

    h5("no_name_attr", "reader-error", lambda f: _first_dataset(f).attrs.__delitem__("name"))
    h5("no_channels", "reader-error", lambda f: f.__delitem__("channels"))
    h5("no_metadata", "reader-error", lambda f: f.__delitem__("metadata"))
    h5("text_rate", "reader-error", lambda f: _first_dataset(f).attrs.__setitem__("sample_rate_hz", "fast"))
    h5("list_position", "reader-error", lambda f: _first_dataset(f).attrs.__setitem__("position_m", "here"))
    h5("group_channel", "reader-error", lambda f: f["channels"].create_group("9999"))
    h5("no_format", "reader-error", lambda f: f.attrs.__delitem__("format"))
    h5("int_name", "reader-error", lambda f: _first_dataset(f).attrs.__setitem__("name", 7))

    def h5_bytes(name, klass, edit):
        raw = bytearray(good_h5.read_bytes())
        (work / f"{name}.h5").write_bytes(bytes(edit(raw)))
        out[name] = (klass, f"{name}.h5")

    h5_bytes("h5_half", "corrupt-file", lambda b: b[: len(b) // 2])
    h5_bytes("h5_flipped", "corrupt-file", _flip_data_bytes)
    h5_bytes("h5_text", "reader-error", lambda b: b"not an HDF5 file\n")
    h5_bytes("h5_empty", "reader-error", lambda b: b"")

    def h5_values(f):
        ds = _first_dataset(f)
        data = ds[...]
        data[10] = 1e30
        ds[...] = data

    h5("h5_huge_value", "corrupt-file", h5_values)

    from exudyn_study.recording.io import read_recording, write_recording
    from exudyn_study.recording.types import Recording

    rec = read_recording(good_h5)
    first = rec.channels[0]
    huge = type(first)(
        first.name,
        first.quantity,
        first.unit,
        first.direction,
        first.position_m,
        first.sample_rate_hz,
        np.where(np.arange(first.n_samples) == 10, 1e30, first.data),
        role=first.role,
        sensitivity=first.sensitivity,
    )
    write_recording(Recording((huge, *rec.channels[1:]), dict(rec.metadata)), work / "h5_huge_written.h5")
    out["h5_huge_written"] = ("corrupt-file", "h5_huge_written.h5")

    text = good_uff.read_bytes()

    def uff(name, klass, data: bytes):
        (work / f"{name}.uff").write_bytes(data)
        out[name] = (klass, f"{name}.uff")

    uff("uff_half", "corrupt-file", text[: len(text) // 2])
    uff("uff_flipped", "corrupt-file", _flip_data_bytes(bytearray(text)))
    uff("uff_garbage", "reader-error", b"    -1\n  58\ngarbage\n" * 5 + b"    -1\n")
    uff("uff_fs_text", "reader-error", text.replace(b"fs=1000.0", b"fs=fast", 1))
    uff("uff_sens_text", "reader-error", _with_sensitivity(text, b"abc"))
    uff("uff_not_utf8", "reader-error", b"\xff\xfe\x00garbage" * 50 + b"\n    -1\n")
    uff("uff_cut_at_set", "corrupt-file", _cut_after_sets(text, 4))
    out["missing"] = ("reader-error", "missing.h5")
    (work / "a_directory.h5").mkdir()
    out["directory"] = ("reader-error", "a_directory.h5")
    (work / "wrong_suffix.mat").write_bytes(good_h5.read_bytes())
    out["wrong_suffix"] = ("reader-error", "wrong_suffix.mat")
    return out


def _flip_data_bytes(raw: bytearray) -> bytearray:
    """Change 8 bytes in the middle of the file (inside the sample data)."""
    mid = len(raw) * 2 // 3
    raw[mid : mid + 8] = bytes((b ^ 0x5A) for b in raw[mid : mid + 8])
    return raw


def _with_sensitivity(text: bytes, value: bytes) -> bytes:
    return text.replace(b"fs=1000.0", b"fs=1000.0 sensitivity=" + value, 1)


def _cut_after_sets(text: bytes, n: int) -> bytes:
    """The file cut right after its n-th closed dataset: a whole-set truncation."""
    pos, count = 0, 0
    marker = b"    -1\n"
    while count < 2 * n:
        pos = text.index(marker, pos) + len(marker)
        count += 1
    return text[:pos]


def _modes_json(work: Path) -> None:
    from exudyn_study.identify.model import ModalModel, Mode

    (work / "T.json").write_text(ModalModel((Mode(12.0, 0.02), Mode(20.0, 0.01))).to_json())


def _bad_jsons(work: Path) -> dict[str, str]:
    """Bad modes/calibration JSON files; return name -> file name."""
    docs = {
        "mode_list": '{"modes": [["a", 0]]}',
        "mode_null": '{"modes": [[null, 0]]}',
        "shape_list": '{"modes": [{"frequency_hz": 10, "damping_ratio": 0.01, "shape": [1, 2]}]}',
        "shape_string": '{"modes": [{"frequency_hz": 10, "damping_ratio": 0.01, "shape": "abc"}]}',
        "metadata_list": '{"modes": [{"frequency_hz": 10, "damping_ratio": 0.01}], "metadata": [1]}',
        "freq_text": '{"modes": [{"frequency_hz": "ten", "damping_ratio": 0.01}]}',
        "huge_int": '{"modes": [{"frequency_hz": 1' + "0" * 5000 + ', "damping_ratio": 0.01}]}',
        "deep": '{"modes": ' + "[" * 100000 + "]" * 100000 + "}",
        "nan": '{"modes": [{"frequency_hz": NaN, "damping_ratio": 0.01}]}',
        "overflow": '{"modes": [{"frequency_hz": 1e400, "damping_ratio": 0.01}]}',
        "top_list": "[1, 2, 3]",
        "top_string": '"modes"',
        "syntax": '{"modes": [',
        "empty_modes": '{"modes": []}',
        "damping_2": '{"modes": [{"frequency_hz": 10, "damping_ratio": 2.0}]}',
    }
    names = {}
    for name, text in docs.items():
        (work / f"j_{name}.json").write_text(text)
        names[name] = f"j_{name}.json"
    (work / "j_not_utf8.json").write_bytes(b'{"modes": [{"description": "\xff\xfe"}]}')
    names["not_utf8"] = "j_not_utf8.json"
    (work / "j_empty.json").write_bytes(b"")
    names["empty_file"] = "j_empty.json"
    return names


def _tomls(work: Path) -> dict[str, tuple[str, str]]:
    """Sweep configurations; return name -> (class, file name)."""
    base = '[study]\ntask = "sleep_cpu"\n[study.settings]\nseconds = 0.0\n'
    docs = {
        "logspace_overflow": (
            "malformed-config",
            '[study]\ntask = "sleep_cpu"\n[parameters]\nseconds = { logspace = [0, 400, 3] }\n',
        ),
        "linspace_huge": (
            "malformed-config",
            '[study]\ntask = "sleep_cpu"\n[parameters]\nseconds = { linspace = [0, 1, 100000000] }\n',
        ),
        "linspace_float_num": (
            "malformed-config",
            '[study]\ntask = "sleep_cpu"\n[parameters]\nseconds = { linspace = [0, 1, 1e8] }\n',
        ),
        "random_huge": (
            "malformed-config",
            '[study]\ntask = "sleep_cpu"\nmode = "random"\n'
            "samples = 100000000\n[parameters]\nseconds = { linspace = [0, 1, 3] }\n",
        ),
        "range_huge": (
            "malformed-config",
            '[study]\ntask = "sleep_cpu"\n[parameters]\nseed = { range = [0, 100000000000] }\n',
        ),
        "grid_product": (
            "malformed-config",
            '[study]\ntask = "sleep_cpu"\n[parameters]\n'
            "seed = { range = [0, 999] }\nsize = { range = [1, 1000] }\n",
        ),
        "syntax": ("malformed-config", "[study\ntask = 1\n"),
        "deep": ("malformed-config", "x = " + "[" * 100000 + "]" * 100000 + "\n"),
        "study_string": ("malformed-config", 'study = "x"\n'),
        "huge_seed": ("malformed-config", '[study]\ntask = "sleep_cpu"\nseed = 1' + "0" * 40 + "\n"),
        "name_parent": (
            "security",
            base.replace('task = "sleep_cpu"', 'task = "sleep_cpu"\nname = "../../x"'),
        ),
        "name_absolute": (
            "security",
            base.replace('task = "sleep_cpu"', 'task = "sleep_cpu"\nname = "/tmp/x"'),
        ),
        "name_dotdot": ("security", base.replace('task = "sleep_cpu"', 'task = "sleep_cpu"\nname = ".."')),
        "name_number": ("security", base.replace('task = "sleep_cpu"', 'task = "sleep_cpu"\nname = 7')),
        "imports": (
            "security",
            base.replace('task = "sleep_cpu"', 'task = "sleep_cpu"\nimports = ["antigravity"]'),
        ),
    }
    names = {}
    for name, (klass, text) in docs.items():
        (work / f"s_{name}.toml").write_text(text)
        names[name] = (klass, f"s_{name}.toml")
    (work / "s_not_utf8.toml").write_bytes(b'[study]\ntask = "\xff\xfe"\n')
    names["not_utf8"] = ("malformed-config", "s_not_utf8.toml")
    (work / "S.toml").write_text(base + "[parameters]\nseed = { range = [0, 1] }\n")
    return names


def _csvs(work: Path) -> None:
    """Time-data exports for ``import``: one valid, the rest each wrong in one way."""
    (work / "T.csv").write_text("t,Fz,a1\n" + "".join(f"{i / 400},{i % 7},{i % 5}\n" for i in range(64)))
    (work / "T_missing.csv").write_text("t,Fz\n0,1\n0.0025,2\n")
    (work / "T_text.csv").write_text("t,Fz,a1\n0,1,2\n0.0025,two,3\n")
    (work / "T_ragged.csv").write_text("t,Fz,a1\n0,1,2\n0.0025,2\n")
    (work / "T_empty.csv").write_text("")
    (work / "T_binary.csv").write_bytes(bytes(range(256)) * 4)


def prepare(work: Path) -> None:
    """Write the valid and bad input files into ``work`` (an empty directory)."""
    from exudyn_study.recording.io import write_recording

    rec = _recording()
    write_recording(rec, work / "F.h5")
    write_recording(rec, work / "G.h5")
    write_recording(rec, work / "F.uff")
    (work / "link.h5").symlink_to("F.h5")
    (work / "sub").mkdir()
    (work / "blocker").write_text("a file where a directory is expected\n")
    (work / "cache").mkdir()
    _modes_json(work)
    _csvs(work)
    written = (_bad_recordings(work, work / "F.h5", work / "F.uff"), _bad_jsons(work), _tomls(work))
    index = (_recordings_index(), _bad_jsons_index(), _tomls_index())
    if written != index:  # the cases name files by these indexes
        raise AssertionError(f"fuzz files and their index differ: {written} != {index}")


# ----------------------------------------------------------------------------- the cases


def cases(work: Path) -> list[Case]:
    """Return every case; ``prepare(work)`` must have written the files they name."""
    out: list[Case] = []

    def add(klass, command, name, *argv):
        out.append(Case(klass, command, name, (command, *argv)))

    rec_names = _recordings_index()
    ident = ("--reference", "ARFVZ")
    # 1. an output that is an input
    add("output-is-input", "identify", "json=input", "F.h5", *ident, "--json", "F.h5")
    add("output-is-input", "identify", "json=input via link", "link.h5", *ident, "--json", "F.h5")
    add("output-is-input", "identify", "json=input other spelling", "F.h5", *ident, "--json", "sub/../F.h5")
    add("output-is-input", "identify", "json=input uff", "F.uff", *ident, "--json", "F.uff")
    add(
        "output-is-input",
        "damage",
        "json=measured",
        "--simulated",
        "F.h5",
        "--measured",
        "G.h5",
        "--json",
        "G.h5",
    )
    add(
        "output-is-input",
        "damage",
        "plot=simulated",
        "--simulated",
        "F.h5",
        "--measured",
        "G.h5",
        "--json",
        "d.json",
        "--plot",
        "link.h5",
    )
    add(
        "output-is-input",
        "calibrate",
        "json=target",
        "--model",
        "1",
        "--target",
        "T.json",
        "--json",
        "T.json",
    )
    add(
        "output-is-input",
        "iterate-drive",
        "out=measured",
        "--model",
        "1",
        "--measured",
        "F.h5",
        "--out",
        "F.h5",
    )
    add(
        "output-is-input",
        "iterate-drive",
        "json=measured",
        "--model",
        "1",
        "--measured",
        "F.h5",
        "--out",
        "o.h5",
        "--json",
        "F.h5",
    )
    add(
        "output-is-input",
        "iterate-drive",
        "out=json",
        "--model",
        "1",
        "--measured",
        "F.h5",
        "--out",
        "o.h5",
        "--json",
        "o.h5",
    )
    add("output-is-input", "simulate", "out=signal", "--model", "1", "--signal", "F.h5", "--out", "F.h5")
    add(
        "output-is-input",
        "diagnose",
        "json=reference",
        "--model",
        "modal:F.h5",
        "--train",
        "G.h5",
        "--holdout",
        "F.h5",
        "--json",
        "F.h5",
    )
    add(
        "output-is-input",
        "diagnose",
        "json=train",
        "--model",
        "1",
        "--train",
        "G.h5",
        "--holdout",
        "F.h5",
        "--json",
        "G.h5",
    )
    add("output-is-input", "sweep", "out=config", "S.toml", "--out", "S.toml")
    add("output-is-input", "virtual-test", "out=recording", "--scenario", "none", "--out", "F.h5")
    add("output-is-input", "demo", "out=recording", "--skip-fe", "--out", "F.h5")
    # 2 and 3. malformed and corrupt recordings, through every command that reads one
    for name, (klass, file) in rec_names.items():
        add(klass, "identify", name, file, *ident, "--json", "o.json")
        add(
            klass,
            "damage",
            f"simulated {name}",
            "--simulated",
            file,
            "--measured",
            "G.h5",
            "--json",
            "o.json",
        )
        add(
            klass, "damage", f"measured {name}", "--simulated", "G.h5", "--measured", file, "--json", "o.json"
        )
        add(klass, "iterate-drive", name, "--model", "1", "--measured", file, "--out", "o.h5")
        add(klass, "simulate", name, "--model", "1", "--signal", file, "--out", "o.h5")
        add(
            klass,
            "diagnose",
            name,
            "--model",
            "modal:G.h5",
            "--train",
            file,
            "--holdout",
            "G.h5",
            "--json",
            "o.json",
        )
    # 4. unwritable outputs
    ro = f"{READ_ONLY_DIR}/exudyn-study-fuzz"
    add("unwritable-output", "identify", "json is a dir", "F.h5", *ident, "--json", "sub")
    add("unwritable-output", "identify", "json below a file", "F.h5", *ident, "--json", "blocker/o.json")
    add("unwritable-output", "identify", "json read-only fs", "F.h5", *ident, "--json", f"{ro}.json")
    add(
        "unwritable-output",
        "identify",
        "plots is a file",
        "F.h5",
        *ident,
        "--json",
        "o.json",
        "--plots",
        "blocker",
    )
    add(
        "unwritable-output",
        "damage",
        "json read-only fs",
        "--simulated",
        "F.h5",
        "--measured",
        "G.h5",
        "--json",
        f"{ro}.json",
    )
    add(
        "unwritable-output",
        "damage",
        "json is a dir",
        "--simulated",
        "F.h5",
        "--measured",
        "G.h5",
        "--json",
        "sub",
    )
    add(
        "unwritable-output",
        "calibrate",
        "json read-only fs",
        "--model",
        "1",
        "--target",
        "T.json",
        "--json",
        f"{ro}.json",
    )
    add(
        "unwritable-output",
        "iterate-drive",
        "out read-only fs",
        "--model",
        "1",
        "--measured",
        "F.h5",
        "--out",
        f"{ro}.h5",
    )
    add("unwritable-output", "simulate", "out is a dir", "--model", "1", "--out", "sub")
    add("unwritable-output", "simulate", "out below a file", "--model", "1", "--out", "blocker/o.h5")
    add("unwritable-output", "modes", "json read-only fs", "--model", "1", "--json", f"{ro}.json")
    add("unwritable-output", "modes", "json is a dir", "--model", "1", "--json", "sub")
    add("unwritable-output", "reduce", "json is a dir", "--json", "sub")
    add("unwritable-output", "reduce", "json read-only fs", "--json", f"{ro}.json")
    add(
        "unwritable-output",
        "diagnose",
        "report is a file",
        "--model",
        "modal:F.h5",
        "--train",
        "G.h5",
        "--holdout",
        "F.h5",
        "--json",
        "o.json",
        "--report",
        "blocker",
    )
    add(
        "unwritable-output",
        "diagnose",
        "json read-only fs",
        "--model",
        "modal:F.h5",
        "--train",
        "G.h5",
        "--holdout",
        "F.h5",
        "--json",
        f"{ro}.json",
    )
    add("unwritable-output", "virtual-test", "out is a file", "--scenario", "none", "--out", "blocker")
    add("unwritable-output", "virtual-test", "out read-only fs", "--scenario", "none", "--out", ro)
    add("unwritable-output", "demo", "out is a file", "--skip-fe", "--out", "blocker")
    add("unwritable-output", "demo", "out read-only fs", "--skip-fe", "--out", ro)
    add("unwritable-output", "sweep", "out is a file", "S.toml", "--out", "blocker")
    add("unwritable-output", "sweep", "out read-only fs", "S.toml", "--out", ro)
    # 5. several outputs, a late one bad: nothing may be left
    add(
        "partial-output",
        "damage",
        "plot suffix",
        "--simulated",
        "F.h5",
        "--measured",
        "G.h5",
        "--json",
        "o.json",
        "--plot",
        "p.xyz",
    )
    add(
        "partial-output",
        "damage",
        "plot below a file",
        "--simulated",
        "F.h5",
        "--measured",
        "G.h5",
        "--json",
        "o.json",
        "--plot",
        "blocker/p.png",
    )
    add("partial-output", "identify", "plots read-only fs", "F.h5", *ident, "--json", "o.json", "--plots", ro)
    add(
        "partial-output",
        "identify",
        "late reference error",
        "F.h5",
        "--reference",
        "NOPE",
        "--json",
        "new/o.json",
        "--plots",
        "new/figs",
    )
    add(
        "partial-output",
        "iterate-drive",
        "json read-only fs",
        "--model",
        "1",
        "--measured",
        "F.h5",
        "--out",
        "o.h5",
        "--json",
        f"{ro}.json",
    )
    add(
        "partial-output",
        "iterate-drive",
        "late control error",
        "--model",
        "1",
        "--measured",
        "F.h5",
        "--out",
        "new/o.h5",
        "--json",
        "new/o.json",
        "--control",
        "NOPE",
    )
    add(
        "partial-output",
        "calibrate",
        "plot suffix",
        "--model",
        "1",
        "--target",
        "T.json",
        "--json",
        "o.json",
        "--plot",
        "p.xyz",
    )
    add(
        "partial-output",
        "calibrate",
        "late target error",
        "--model",
        "1",
        "--target",
        "j_mode_list.json",
        "--json",
        "new/o.json",
        "--plot",
        "new/p.png",
    )
    add(
        "partial-output",
        "virtual-test",
        "level out of range",
        "--scenario",
        "none",
        "--level",
        "1",
        "100",
        "--out",
        "new",
    )
    add("partial-output", "virtual-test", "unknown scenario", "--scenario", "nope", "--out", "new")
    add("partial-output", "reduce", "json below a file", "--json", "blocker/r.json")
    add("partial-output", "demo", "bad mesh", "--mesh", "fine", "--out", "new")
    add(
        "partial-output",
        "diagnose",
        "late holdout error",
        "--model",
        "modal:F.h5",
        "--train",
        "G.h5",
        "--holdout",
        "missing.h5",
        "--json",
        "new/o.json",
        "--report",
        "new/report",
    )
    add("partial-output", "simulate", "out suffix", "--model", "1", "--out", "o.txt")
    # 6. absurd values
    absurd = {
        "simulate": [
            ("--duration", "1e9"),
            ("--duration", "1e5"),
            ("--duration", "0"),
            ("--duration", "nan"),
            ("--step", "1e-12"),
            ("--step", "1"),
            ("--mesh", "1e-9"),
            ("--mesh", "1e9"),
            ("--mesh", "fine"),
            ("--rms", "1e300"),
            ("--rms", "-1"),
            ("--seed", "1" + "0" * 22),
            ("--seed", "-1"),
            ("--seed", "1.5"),
            ("--model", "4"),
            ("--method", "euler"),
            ("--damping", "rayleigh"),
            ("--signal", "pink-noise"),
        ],
        "reduce": [
            ("--mesh", "1e-6"),
            ("--mesh", "1e9"),
            ("--max-frequency", "0"),
            ("--max-frequency", "1e9"),
            ("--component", "spare_wheel"),
            ("--body", "truck"),
        ],
        "modes": [
            ("--n-modes", "-3"),
            ("--n-modes", "0"),
            ("--max-frequency", "-5"),
            ("--max-frequency", "inf"),
            ("--mesh", "0"),
            ("--model", "0"),
        ],
        "damage": [
            ("--beta", "1e308"),
            ("--beta", "0"),
            ("--beta", "-2"),
            ("--rate", "0"),
            ("--rate", "nan"),
        ],
        "identify": [
            ("--resolution", "0"),
            ("--resolution", "1e-9"),
            ("--max-order", "1000000"),
            ("--max-order", "2"),
            ("--band", "50", "3"),
            ("--band", "nan", "3"),
            ("--pin", "-4"),
            ("--estimator", "H3"),
        ],
        "iterate-drive": [
            ("--iterations", "1000000"),
            ("--iterations", "-1"),
            ("--tolerance", "inf"),
            ("--tolerance", "0"),
            ("--regularization", "-1"),
            ("--reg", "1e300"),
            ("--model", "9"),
            ("--frf", "guess"),
        ],
        "calibrate": [
            ("--mac-min", "2"),
            ("--freq-tol", "0"),
            ("--above-percent", "120"),
            ("--max-frequency", "-1"),
            ("--cutoff-hz", "1e12"),
            ("--regularization", "-1"),
            ("--other-damping", "x"),
        ],
        "virtual-test": [
            ("--level", "100"),
            ("--level", "0"),
            ("--duration", "-1"),
            ("--duration", "1e9"),
            ("--seed", "-1"),
            ("--signal", "sweep"),
        ],
        "demo": [("--seed", "-1"), ("--mesh", "1e-9"), ("--seed", "9" * 30)],
        "diagnose": [
            ("--resolution", "0"),
            ("--resolution", "1e9"),
            ("--model", "7"),
            ("--interface", "A2"),
            ("--workers", "0"),
            ("--workers", "1e9"),
        ],
        "sweep": [("--workers", "0"), ("--workers", "1e9")],
    }
    base_args = {
        "simulate": ("--model", "1", "--out", "o.h5"),
        "reduce": ("--json", "r.json"),
        "modes": ("--model", "1", "--json", "o.json"),
        "damage": ("--simulated", "F.h5", "--measured", "G.h5", "--json", "o.json"),
        "identify": ("F.h5", *ident, "--json", "o.json"),
        "iterate-drive": ("--model", "1", "--measured", "F.h5", "--out", "o.h5"),
        "calibrate": ("--model", "1", "--target", "T.json", "--json", "o.json"),
        "virtual-test": ("--scenario", "none", "--out", "new"),
        "demo": ("--skip-fe", "--out", "new"),
        "diagnose": ("--model", "modal:F.h5", "--train", "G.h5", "--holdout", "F.h5", "--json", "o.json"),
        "sweep": ("S.toml", "--out", "new"),
    }
    for command, options in absurd.items():
        for option, *values in options:
            args = list(base_args[command])
            if option in args:  # replace the base value (e.g. --model)
                i = args.index(option)
                del args[i : i + 2]
            add("absurd-value", command, f"{option} {' '.join(values)}", *args, option, *values)
    add(
        "absurd-value",
        "reduce",
        "component of the rear foundation",
        "--body",
        "rear_foundation",
        "--component",
        "frame",
        "--json",
        "r.json",
    )
    # 7. malformed JSON/TOML
    for name, file in _bad_jsons_index().items():
        add(
            "malformed-config",
            "calibrate",
            f"target {name}",
            "--model",
            "1",
            "--target",
            file,
            "--json",
            "o.json",
        )
        add(
            "malformed-config",
            "iterate-drive",
            f"calibration {name}",
            "--model",
            "1",
            "--damping",
            "suggested",
            "--calibration",
            file,
            "--measured",
            "F.h5",
            "--control",
            "ARFVZ",
            "--out",
            "o.h5",
        )
    for name, (klass, file) in _tomls_index().items():
        add(klass, "sweep", name, file, "--out", "new", "--dry-run")
    # 8. cache directories that cannot be one
    for command, args in (
        ("simulate", base_args["simulate"]),
        ("modes", base_args["modes"]),
        ("reduce", base_args["reduce"]),
        ("calibrate", base_args["calibrate"]),
        ("iterate-drive", base_args["iterate-drive"]),
        ("virtual-test", base_args["virtual-test"]),
        ("demo", ("--out", "new")),
        ("diagnose", ("--model", "1", "--train", "G.h5", "--holdout", "F.h5", "--json", "o.json")),
    ):
        add("cache", command, "cache dir is a file", *args, "--cache-dir", "blocker")
        add("cache", command, "cache dir below a file", *args, "--cache-dir", "blocker/cache")
    # 9. sweep options
    add(
        "sweep",
        "sweep",
        "scheduler unreachable",
        "S.toml",
        "--out",
        "new",
        "--scheduler",
        "tcp://127.0.0.1:9",
    )
    add("sweep", "sweep", "scheduler not a url", "S.toml", "--out", "new", "--scheduler", "localhost")
    rig = ("--model", "1", "--train", "G.h5", "--holdout", "F.h5", "--json", "o.json")
    add("sweep", "diagnose", "scheduler unreachable", *rig, "--scheduler", "tcp://127.0.0.1:9")
    add("sweep", "diagnose", "scheduler not a url", *rig, "--scheduler", "http://somewhere")
    add("sweep", "diagnose", "workers on the modal path", *base_args["diagnose"], "--workers", "2")
    add("sweep", "sweep", "plot-x not swept", "S.toml", "--out", "new", "--plot-x", "size")
    add("cache", "sweep", "cache dir is a file", "S.toml", "--out", "new", "--cache-dir", "blocker")
    add("sweep", "sweep", "config missing", "missing.toml", "--out", "new")
    add("sweep", "sweep", "config is a directory", "sub", "--out", "new")
    add("sweep", "sweep", "config not utf8", "s_not_utf8.toml", "--out", "new")
    # 10. import: CSV/TSV time data through a column map
    cmap = ("--column", "force=Fz:force:N:Z:drive", "--column", "DP=a1:acceleration:g")
    add("output-is-input", "import", "out=input", "F.h5", *cmap, "--rate", "400", "--out", "F.h5")
    add("reader-error", "import", "column missing", "T_missing.csv", *cmap, "--rate", "400", "--out", "n.h5")
    add("reader-error", "import", "column not numeric", "T_text.csv", *cmap, "--rate", "400", "--out", "n.h5")
    add("reader-error", "import", "rows of unequal length", "T_ragged.csv", *cmap, "--rate", "400",
        "--out", "n.h5")
    add("reader-error", "import", "no rate", "T.csv", *cmap, "--out", "n.h5")
    add("reader-error", "import", "column map malformed", "T.csv", "--column", "force", "--rate", "400",
        "--out", "n.h5")
    add("corrupt-file", "import", "empty file", "T_empty.csv", *cmap, "--rate", "400", "--out", "n.h5")
    add("corrupt-file", "import", "binary file", "T_binary.csv", *cmap, "--rate", "400", "--out", "n.h5")
    add("corrupt-file", "import", "file missing", "missing.csv", *cmap, "--rate", "400", "--out", "n.h5")
    add("unwritable-output", "import", "out is a dir", "T.csv", *cmap, "--rate", "400", "--out", "sub")
    add("unwritable-output", "import", "out below a file", "T.csv", *cmap, "--rate", "400",
        "--out", "blocker/n.h5")
    add("unwritable-output", "import", "out not a recording", "T.csv", *cmap, "--rate", "400",
        "--out", "n.txt")
    add("absurd-value", "import", "rate zero", "T.csv", *cmap, "--rate", "0", "--out", "n.h5")
    add("absurd-value", "import", "rate 1e300", "T.csv", *cmap, "--rate", "1e300", "--out", "n.h5")
    add("absurd-value", "import", "rate nan", "T.csv", *cmap, "--rate", "nan", "--out", "n.h5")
    return out


def _recordings_index() -> dict[str, tuple[str, str]]:
    reader = (
        "no_name_attr",
        "no_channels",
        "no_metadata",
        "text_rate",
        "list_position",
        "group_channel",
        "no_format",
        "int_name",
        "h5_text",
        "h5_empty",
    )
    corrupt = ("h5_half", "h5_flipped", "h5_huge_value", "h5_huge_written")
    out = {n: ("reader-error", f"{n}.h5") for n in reader}
    out.update({n: ("corrupt-file", f"{n}.h5") for n in corrupt})
    out.update({n: ("corrupt-file", f"{n}.uff") for n in ("uff_half", "uff_flipped", "uff_cut_at_set")})
    out.update(
        {
            n: ("reader-error", f"{n}.uff")
            for n in ("uff_garbage", "uff_fs_text", "uff_sens_text", "uff_not_utf8")
        }
    )
    out.update(
        {
            "missing": ("reader-error", "missing.h5"),
            "directory": ("reader-error", "a_directory.h5"),
            "wrong_suffix": ("reader-error", "wrong_suffix.mat"),
        }
    )
    return out


def _bad_jsons_index() -> dict[str, str]:
    names = (
        "mode_list",
        "mode_null",
        "shape_list",
        "shape_string",
        "metadata_list",
        "freq_text",
        "huge_int",
        "deep",
        "nan",
        "overflow",
        "top_list",
        "top_string",
        "syntax",
        "empty_modes",
        "damping_2",
        "not_utf8",
    )
    out = {n: f"j_{n}.json" for n in names}
    out["empty_file"] = "j_empty.json"
    return out


def _tomls_index() -> dict[str, tuple[str, str]]:
    malformed = (
        "logspace_overflow",
        "linspace_huge",
        "linspace_float_num",
        "random_huge",
        "range_huge",
        "grid_product",
        "syntax",
        "deep",
        "study_string",
        "huge_seed",
        "not_utf8",
    )
    security = ("name_parent", "name_absolute", "name_dotdot", "name_number", "imports")
    out = {n: ("malformed-config", f"s_{n}.toml") for n in malformed}
    out.update({n: ("security", f"s_{n}.toml") for n in security})
    return out


# ----------------------------------------------------------------------------- running a case


def snapshot(work: Path) -> dict[str, str]:
    """Relative path -> SHA-256 (files) or 'dir' / 'link' of everything under ``work``."""
    out = {}
    for root, dirs, files in os.walk(work):
        for d in dirs:
            p = Path(root) / d
            out[str(p.relative_to(work))] = "dir"
        for f in files:
            p = Path(root) / f
            rel = str(p.relative_to(work))
            out[rel] = "link" if p.is_symlink() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout(f"no answer within {CASE_TIMEOUT_S} s")


def run_in_process(case: Case, work: Path) -> Outcome:
    """Run ``case`` through ``exudyn_study.cli.main`` in this process (cwd = ``work``)."""
    from exudyn_study.cli import main

    before = snapshot(work)
    err, out = io.StringIO(), io.StringIO()
    code, exception = None, ""
    cwd = os.getcwd()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_TIMEOUT_S)
    t0 = time.perf_counter()
    try:
        os.chdir(work)
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = main(list(case.argv))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else None
    except BaseException as exc:  # noqa: BLE001 - every escape is a finding of the fuzz suite
        exception = f"{type(exc).__name__}: {' '.join(str(exc).split())[:160]}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
        os.chdir(cwd)
    return _outcome(case, work, before, code, err.getvalue(), exception, time.perf_counter() - t0)


def run_in_subprocess(case: Case, work: Path, env: dict | None = None) -> Outcome:
    """Run ``case`` as ``python -m exudyn_study.cli`` in a fresh process (cwd = ``work``)."""
    before = snapshot(work)
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "exudyn_study.cli", *case.argv],
            cwd=work,
            capture_output=True,
            text=True,
            timeout=CASE_TIMEOUT_S * 3,
            env=env,
            stdin=subprocess.DEVNULL,
        )
        code, stderr, exception = proc.returncode, proc.stderr, ""
    except subprocess.TimeoutExpired:
        code, stderr, exception = None, "", "timeout"
    return _outcome(case, work, before, code, stderr, exception, time.perf_counter() - t0)


def _outcome(case, work, before, code, stderr, exception, wall_s) -> Outcome:
    after = snapshot(work)
    new = tuple(sorted(set(after) - set(before)))
    changed = tuple(sorted(k for k in before if after.get(k) != before[k]))
    for rel in new:  # clean up, so that the next case starts from the same files
        p = work / rel
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
    return Outcome(case, code, stderr, new, changed, exception, wall_s)


def tally(outcomes: list[Outcome]) -> dict:
    """Figures by class: cases tried, handled cleanly, and the failures' descriptions."""
    figures: dict = {"tried": len(outcomes), "clean": sum(o.ok for o in outcomes), "by_class": {}}
    for klass in CLASSES:
        mine = [o for o in outcomes if o.case.klass == klass]
        figures["by_class"][klass] = {
            "tried": len(mine),
            "clean": sum(o.ok for o in mine),
            "commands": sorted({o.case.command for o in mine}),
            "failures": [
                f"{o.case.command} {o.case.name}: {', '.join(o.problems)}" for o in mine if not o.ok
            ],
        }
    return figures


def as_json(figures: dict) -> str:
    """Return the figures as indented JSON."""
    return json.dumps(figures, indent=1)
