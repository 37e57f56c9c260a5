"""``exudyn-study modes``: system modes of a model variant on the rig.

Builds (or loads from cache) the flexible bodies of the variant, assembles the rig,
linearises it with Exudyn and writes the damped modes in the modes-JSON schema of the
identification module (``frequency_hz``, ``damping_ratio``, ``description``, ``shape``
per sensor), so computed and identified modes can be compared directly.
"""

from __future__ import annotations

import argparse
import sys

from exudyn_study.bodies.damping import parse_damping
from exudyn_study.cli.options import Bounded, add_cache_dir, add_damping, add_mesh
from exudyn_study.linear.modes import modes_table

__all__ = ["configure", "run", "modes_table"]


DAMPINGS = ("adams-default", "step", "constant-1", "constant-2", "table6")
MAX_FREQUENCY = Bounded(float, 0.0, 1000.0, "Hz", "the rig models are built for the band below a few 100 Hz; "
                        "above 1000 Hz the flexible bodies keep no modes", low_open=True)
N_MODES = Bounded(int, 1, 10000, "", "a count of modes")


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``modes`` arguments."""
    parser.add_argument("--model", type=int, choices=(1, 2, 3), required=True, help="rig model variant")
    add_damping(parser, DAMPINGS, help_text="damping function (table6: thesis Table 6 per body, model 3)")
    add_mesh(parser)
    parser.add_argument("--bushing", action="store_true",
                        help="model 3: join the components by 6-DOF spring-damper bushings "
                             "(default: fixed joints)")
    parser.add_argument("--max-frequency", type=MAX_FREQUENCY, default=100.0, metavar="HZ",
                        help="highest mode frequency in Hz")
    parser.add_argument("--n-modes", type=N_MODES, default=None, metavar="N",
                        help="at most this many modes (default: all up to --max-frequency)")
    parser.add_argument("--formulation", default="linear", choices=("linear", "ffrf"),
                        help="flexible-body formulation (same linearised system)")
    add_cache_dir(parser)
    parser.add_argument("--json", required=True, metavar="OUT", help="output modes JSON file")


def run(args: argparse.Namespace) -> int:
    """Build, linearise, write the modes JSON and print the table."""
    from tqdm import tqdm

    from exudyn_study.identify.model import write_modes_json
    from exudyn_study.infra.cache import cache_dir
    from exudyn_study.infra.files import OutputSet
    from exudyn_study.linear.modes import to_modal_model
    from exudyn_study.model import BushingParameters, build_model
    from exudyn_study.model.linearisation import linearise, system_modes

    damping = parse_damping(args.damping)
    with OutputSet() as outputs:
        out = outputs.file(args.json, "--json")
        cache_dir(args.cache_dir)
        quiet = True if getattr(args, "quiet", False) else None
        with tqdm(total=3, desc="modes", file=sys.stderr, disable=quiet) as bar:
            model = build_model(args.model, damping=damping, mesh_size=args.mesh,
                                bushing=BushingParameters() if args.bushing else None,
                                cache_dir=args.cache_dir, formulation=args.formulation,
                                progress=lambda text: bar.set_postfix_str(text))
            bar.update()
            bar.set_postfix_str("linearising")
            lin = linearise(model)
            bar.update()
            bar.set_postfix_str("eigenvalues")
            modes = system_modes(model, lin, max_frequency_hz=args.max_frequency, n_modes=args.n_modes)
            bar.update()
        write_modes_json(to_modal_model(modes, model.metadata), out)
    print(modes_table(modes))
    return 0
