"""Console-script subcommands of the foundation: reduce (bad input) and the demo (smoke)."""

from __future__ import annotations

import json

import pytest

from exudyn_study.cli import main


def test_reduce_rejects_bad_mesh_argument(capsys, tmp_path):
    out = tmp_path / "r.json"
    code = main(["reduce", "--mesh", "fine-ish", "--json", str(out)])
    assert code == 2
    err = capsys.readouterr().err
    assert "--mesh 'fine-ish'" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_reduce_rejects_unknown_component(capsys, tmp_path):
    out = tmp_path / "r.json"
    code = main(["reduce", "--component", "spare_wheel", "--json", str(out)])
    assert code == 2
    assert "spare_wheel" in capsys.readouterr().err
    assert not out.exists()


def test_reduce_rejects_non_positive_max_frequency(capsys):
    assert main(["reduce", "--max-frequency", "0"]) == 2
    assert "--max-frequency 0: out of range; expected > 0 and <= 2000 Hz" in capsys.readouterr().err


def test_help_lists_the_subcommands(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    for name in ("demo", "reduce", "identify", "damage"):
        assert name in text


def test_demo_identification_part_runs(tmp_path, capsys):
    """The demo without its FE step: recording written, modes identified, figures drawn; its steps
    counted [1/2], [2/2] (each announced before it runs)."""
    import re

    code = main(["demo", "--skip-fe", "--out", str(tmp_path)])
    assert code == 0
    steps = re.findall(r"^\[(\d+)/(\d+)\] ", capsys.readouterr().out, flags=re.M)
    assert steps == [("1", "2"), ("2", "2")]
    modes = json.loads((tmp_path / "modes.json").read_text())["modes"]
    # ten Table-1 modes in 3-50 Hz (see the identification issue for the accuracy figures)
    assert 9 <= len(modes) <= 11
    assert (tmp_path / "test_white_noise.h5").exists()
    assert (tmp_path / "figures" / "stabilisation.png").exists()


def test_verbosity_options_after_the_subcommand():
    from exudyn_study.cli import build_parser

    parser = build_parser()
    args = parser.parse_args(["reduce", "-v"])
    assert args.verbose and not args.quiet
    args = parser.parse_args(["reduce", "--quiet"])
    assert args.quiet and not args.verbose
    args = parser.parse_args(["-v", "reduce"])
    assert args.verbose


def test_warnings_are_one_clean_line_each_repeats_counted_once(monkeypatch, capsys):
    """warnings.warn and logging warnings go through one path: 'warning: ...', a repeat printed once."""
    import logging
    import warnings

    import exudyn_study.cli.reduce as reduce_cli

    def run(args):
        for _ in range(3):
            warnings.warn("the same thing\n  twice", UserWarning, stacklevel=1)
        logging.getLogger("exudyn_study.test").warning("from logging")
        warnings.warn("another thing", RuntimeWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(reduce_cli, "run", run)
    assert main(["reduce"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == ["warning: the same thing twice", "warning: from logging", "warning: another thing",
                   "warning: 2 repeat(s) of 1 warning(s) above not shown again"]


def test_usage_errors_are_one_line(capsys):
    assert main(["reduce", "--no-such-option"]) == 2
    err = capsys.readouterr().err
    assert err == "exudyn-study: error: unrecognized arguments: --no-such-option (see exudyn-study --help)\n"
    assert main(["simulate", "--model", "1", "--out", "x.h5", "--duration", "1e9"]) == 2
    err = capsys.readouterr().err
    assert err == ("exudyn-study simulate: error: --duration 1e9: out of range; expected > 0 and <= 3600 s "
                   "(43 channels at 1000 Hz hold 1.2 GB per hour in memory; a rig test record is 60-120 s) "
                   "(see exudyn-study simulate --help)\n")
