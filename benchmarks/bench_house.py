"""The house's shape, counted: what a newcomer who must change the code meets.

Counts, from the source alone (nothing is imported): import circles between modules, imports of
``exudyn_study.cli`` from the library, private names imported from another package, files over
800 lines, functions over 100 lines, function-local imports, lines that narrate history (session
numbers, commit hashes, "was ... before") in code and docs, and the README's length.

Run:  python benchmarks/bench_house.py [--list] [--no-results]
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "exudyn_study"
HISTORY = re.compile(
    r"session[ -]?[0-9]|sessions [0-9]|(since|before|until|after) [0-9a-f]{7,40}\b|\bwas .* before\b",
    re.IGNORECASE,
)


def _tests_module():
    sys.path.insert(0, str(ROOT / "tests"))
    import test_architecture  # the import graph and cycle finder the tests use

    return test_architecture


def house_figures(list_them: bool = False) -> dict:
    """Count the figures listed in the module docstring; print the offenders with ``list_them``."""
    arch = _tests_module()
    edges = arch._edges()
    cycles = arch._cycles(edges)
    cli_imports = [f"{m}:{line}" for m in arch.MODULES if not m.startswith("exudyn_study.cli")
                   for target, _, line in arch._imports(m) if target.startswith("exudyn_study.cli")]
    private = []
    for module in arch.MODULES:
        for target, name, line in arch._imports(module):
            if name and name.startswith("_") and not name.startswith("__"):
                source = target if target in arch.MODULES and arch.MODULES[target].name == "__init__.py" \
                    else target.rsplit(".", 1)[0]
                if not arch._package_of(module).startswith(source):
                    private.append(f"{module}:{line} {target}.{name}")
    big_files, long_functions, local_imports = [], [], 0
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text()
        rel = str(path.relative_to(ROOT))
        if text.count("\n") > 800:
            big_files.append((rel, text.count("\n")))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > 100:
                    long_functions.append((f"{rel}:{node.name}", length))
                local_imports += sum(isinstance(sub, (ast.Import, ast.ImportFrom)) for sub in ast.walk(node))
    history = []
    for path in [*ROOT.glob("*.md"), *ROOT.glob("*.toml"), *(ROOT / "docs").glob("*.md"),
                 *PACKAGE.rglob("*.py"), *(ROOT / "tests").rglob("*.py"), *(ROOT / "benchmarks").glob("*.py"),
                 *(ROOT / "studies").glob("*.py")]:
        if path.name == "bench_house.py":
            continue
        for i, line in enumerate(path.read_text().splitlines(), 1):
            if HISTORY.search(line):
                history.append(f"{path.relative_to(ROOT)}:{i}")
    figures = {
        "import_circles": len(cycles),
        "library_imports_of_cli": len(cli_imports),
        "private_names_across_packages": len(private),
        "files_over_800_lines": len(big_files),
        "functions_over_100_lines": len(long_functions),
        "function_local_imports": local_imports,
        "history_lines": len(history),
        "readme_lines": (ROOT / "README.md").read_text().count("\n"),
        "modules": len(arch.MODULES),
    }
    if list_them:
        for title, rows in (("circles", cycles), ("library -> cli", cli_imports), ("private", private),
                            ("files > 800 lines", sorted(big_files, key=lambda r: -r[1])),
                            ("functions > 100 lines", sorted(long_functions, key=lambda r: -r[1])),
                            ("history", history)):
            print(f"{title}:")
            for row in rows:
                print(f"  {row}")
    return figures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--list", action="store_true", help="print every offender, not only the counts")
    parser.add_argument("--no-results", action="store_true",
                        help="do not write benchmarks/results/bench_house.json")
    args = parser.parse_args(argv)
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    figures = house_figures(args.list)
    for key, value in figures.items():
        print(f"{key:32s} {value}")
    if not args.no_results:
        write_results("bench_house", figures, args=args, start=run)
    return 0


if __name__ == "__main__":
    sys.exit(main())
