"""``exudyn-study modes``: system modes of a model variant on the rig.

Builds (or loads from cache) the flexible bodies of the variant, assembles the rig,
linearises it with Exudyn and writes the damped modes in the modes-JSON schema of the
identification module (``frequency_hz``, ``damping_ratio``, ``description``, ``shape``
per sensor), so computed and identified modes can be compared directly.
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["configure", "run", "modes_table"]


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``modes`` arguments."""
    parser.add_argument("--model", type=int, required=True, help="model variant: 1, 2 or 3")
    parser.add_argument("--damping", default="adams-default",
                        help="damping function: adams-default, step, constant-1, constant-2, "
                             "or table6 (thesis Table 6 per body, model 3)")
    parser.add_argument("--mesh", default="production", help="mesh size: production (default), coarse or a size in m")
    parser.add_argument("--bushing", action="store_true",
                        help="model 3: join the components by 6-DOF spring-damper bushings (default: fixed joints)")
    parser.add_argument("--max-frequency", type=float, default=100.0, help="highest mode frequency in Hz")
    parser.add_argument("--n-modes", type=int, default=None, help="at most this many modes")
    parser.add_argument("--formulation", default="linear", choices=("linear", "ffrf"),
                        help="flexible-body formulation (same linearised system; default linear)")
    parser.add_argument("--cache-dir", default=None, help="flexible-body cache directory")
    parser.add_argument("--json", required=True, help="output modes JSON file")


def parse_damping(name: str):
    """A damping name from the command line (``table6`` is thesis Table 6)."""
    from .damping import THESIS_TABLE6, damping_function

    if name == "table6":
        return THESIS_TABLE6
    damping_function(name)  # validates
    return name


def parse_mesh(text: str):
    """'coarse', 'production' or a size in m."""
    from .errors import InputError

    if text in ("coarse", "production"):
        return text
    try:
        return float(text)
    except ValueError:
        raise InputError(f"--mesh {text!r}: expected coarse, production or an element size in m") from None


def modes_table(modes, fmt: str = "text") -> str:
    """The thesis-style table (mode, frequencies, damping, description) as text or markdown."""
    rows = [(j + 1, modes.undamped_frequency_hz[j] if j < modes.undamped_frequency_hz.size else float("nan"),
             modes.frequency_hz[j], 100 * modes.damping_ratio[j], modes.descriptions[j])
            for j in range(modes.frequency_hz.size)]
    if fmt == "markdown":
        lines = ["| Mode | Undamped f (Hz) | f (Hz) | Damping (%) | Mode shape |", "|---|---|---|---|---|"]
        lines += [f"| {n} | {fu:.2f} | {f:.2f} | {z:.2f} | {d} |" for n, fu, f, z, d in rows]
    else:
        lines = [f"{'mode':>4} {'f0 (Hz)':>9} {'f (Hz)':>9} {'zeta (%)':>9}  description"]
        lines += [f"{n:4d} {fu:9.2f} {f:9.2f} {z:9.2f}  {d}" for n, fu, f, z, d in rows]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Build, linearise, write the modes JSON and print the table."""
    from pathlib import Path

    from tqdm import tqdm

    from .errors import InputError
    from .identify.model import write_modes_json
    from .modal import linearize, system_modes, to_modal_model
    from .model import BushingParameters, build_model

    out = Path(args.json)
    if not out.parent.is_dir():
        raise InputError(f"--json {args.json!r}: directory {str(out.parent)!r} does not exist")
    damping = parse_damping(args.damping)
    with tqdm(total=3, desc="modes", file=sys.stderr, disable=None) as bar:
        model = build_model(args.model, damping=damping, mesh_size=parse_mesh(args.mesh),
                            bushing=BushingParameters() if args.bushing else None, cache_dir=args.cache_dir,
                            formulation=args.formulation, progress=lambda text: bar.set_postfix_str(text))
        bar.update()
        bar.set_postfix_str("linearising")
        lin = linearize(model)
        bar.update()
        bar.set_postfix_str("eigenvalues")
        modes = system_modes(model, lin, max_frequency_hz=args.max_frequency, n_modes=args.n_modes)
        bar.update()
    write_modes_json(to_modal_model(modes, model.metadata), out)
    print(modes_table(modes))
    return 0
