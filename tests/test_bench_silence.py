"""``benchmarks/bench_silence.py``: the time to the first output and the silent gaps of a command.

The gap analysis is checked on made-up chunks; the capture on a short command under a
pseudo-terminal (a second, no FE).
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
spec = importlib.util.spec_from_file_location("_bench_silence", BENCHMARKS / "bench_silence.py")
bench = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = bench  # dataclasses look their module up by name
spec.loader.exec_module(bench)


def test_gaps_longest_first_with_the_line_shown_before_each():
    """A bar redrawn with carriage returns counts as output; the line before a gap is the last one drawn
    (colour codes removed); the stretch from the last output to the end is a gap too."""
    chunks = [
        (0.5, b"\x1b[?25l"),  # an invisible control sequence is not output yet
        (1.2, b"[1/3] chassis body\n"),
        (2.0, b"\rbuilding [00:01] stage 0/4, mesh"),
        (40.0, b"\rbuilding [00:39] stage 1/4, \x1b[1mreduction\x1b[0m"),
        (41.0, b"\n[2/3] test\n"),
    ]
    first, gaps = bench.silences(chunks, end_s=50.0)
    assert first == 1.2
    assert [round(g.length_s, 6) for g in gaps] == [38.0, 9.0, 1.0, 0.8]
    assert gaps[0].line_before == "building [00:01] stage 0/4, mesh" and gaps[0].start_s == 2.0
    assert gaps[1].line_before == "[2/3] test"
    assert bench.silences([], 3.0) == (None, [])


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")
def test_capture_sees_each_output_as_it_arrives_on_a_terminal(tmp_path):
    """The command writes to a terminal (so a progress bar would be drawn), one line, a pause of 0.6 s,
    a carriage-return update: the pause is measured as it happened, not at the end of the run."""
    code = ("import sys, time; print('start', flush=True); time.sleep(0.6); "
            "sys.stderr.write('tty' if sys.stderr.isatty() else 'pipe'); sys.stderr.write('\\r'); "
            "time.sleep(0.1)")
    chunks, end_s, rc = bench.run_captured([sys.executable, "-c", code], dict(os.environ), tmp_path / "o.log",
                                           timeout_s=60)
    first, gaps = bench.silences(chunks, end_s)
    assert rc == 0 and first is not None and first < 5.0
    assert 0.5 < gaps[0].length_s < 5.0 and gaps[0].line_before == "start"
    assert b"tty" in (tmp_path / "o.log").read_bytes()
