"""Fuzz suite: generated bad inputs per defect class and subcommand (see ``fuzz_cases.py``).

Every case must exit with code 2, print one line on stderr and no traceback, leave nothing
behind and keep every input byte-identical. The default run calls ``exudyn_study.cli.main``
in process (seconds); ``benchmarks/bench_fuzz.py`` runs the same cases in fresh processes
too and writes the figures by class. A few cases here run as a subprocess, since only a
real process shows what a user sees on the terminal.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import fuzz_cases  # noqa: E402  (the case generator beside this file)


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    directory = tmp_path_factory.mktemp("fuzz")
    fuzz_cases.prepare(directory)
    return directory


@pytest.fixture(scope="module")
def outcomes(work):
    import os

    old = os.environ.get("EXUDYN_STUDY_CACHE")
    os.environ["EXUDYN_STUDY_CACHE"] = str(work / "cache")  # nothing may be built: an empty cache
    try:
        return [fuzz_cases.run_in_process(c, work) for c in fuzz_cases.cases(work)]
    finally:
        if old is None:
            os.environ.pop("EXUDYN_STUDY_CACHE", None)
        else:
            os.environ["EXUDYN_STUDY_CACHE"] = old


def test_every_class_and_every_subcommand_is_fuzzed(work):
    from exudyn_study.cli import SUBCOMMANDS

    cases = fuzz_cases.cases(work)
    assert {c.klass for c in cases} == set(fuzz_cases.CLASSES)
    assert {c.command for c in cases} == set(SUBCOMMANDS)
    assert len(cases) >= 300


@pytest.mark.parametrize("klass", fuzz_cases.CLASSES)
def test_every_bad_input_is_refused_cleanly(outcomes, klass):
    mine = [o for o in outcomes if o.case.klass == klass]
    failures = [f"{o.case.command} {o.case.name}: {', '.join(o.problems)} | {o.stderr.strip()[:200]}"
                for o in mine if not o.ok]
    assert not failures, "\n".join(failures)


def test_the_messages_name_the_input(outcomes):
    """A message names the option or the file it is about, so the user knows what to fix."""
    for o in outcomes:
        text = o.stderr
        named = [a for a in o.case.argv[1:] if len(a) > 1]
        assert any(a in text for a in named) or "required" in text, (o.case, text)


@pytest.mark.parametrize("argv", [
    ("identify", "F.h5", "--reference", "ARFVZ", "--json", "F.h5"),
    ("damage", "--simulated", "uff_half.uff", "--measured", "G.h5", "--json", "o.json"),
    ("simulate", "--model", "1", "--duration", "1e9", "--out", "o.h5"),
])
def test_the_console_script_shows_one_line(work, argv):
    outcome = fuzz_cases.run_in_subprocess(fuzz_cases.Case("subprocess", argv[0], "console", argv), work)
    assert outcome.ok, (outcome.problems, outcome.stderr)


@pytest.mark.slow  # one fresh process per case: minutes; benchmarks/bench_fuzz.py runs it with figures
def test_every_bad_input_is_refused_cleanly_in_a_fresh_process(work):
    import os

    env = {**os.environ, "EXUDYN_STUDY_CACHE": str(work / "cache")}
    outcomes = [fuzz_cases.run_in_subprocess(c, work, env) for c in fuzz_cases.cases(work)]
    failures = [f"{o.case.command} {o.case.name}: {', '.join(o.problems)}" for o in outcomes if not o.ok]
    assert not failures, "\n".join(failures)
