"""Study: Model 1 on the rig (one flexible chassis body, simplified bolted joints).

The analogue of the thesis's Table 2: the first ten system modes (undamped and damped
frequency, damping ratio, which component moves most), printed and saved as markdown
and CSV, and a plot of the mode shapes at the 42 sensors (PNG).

``python studies/model1.py [--mesh production] [--damping adams-default] [--out results/studies]``

Models 2 and 3 (``model2.py``, ``model3.py``) reuse :func:`run`. Building a chassis body
from scratch takes minutes; it is cached (``~/.cache/exudyn_study``).
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

N_MODES = 10


def modes_of(variant: int, damping: str, mesh: str, bushing=None, max_frequency_hz: float = 150.0):
    """(model, system modes) of a variant: built, assembled and linearised."""
    from exudyn_study.infra.progress import StageProgress
    from exudyn_study.model import build_model
    from exudyn_study.model.linearisation import linearise, system_modes

    what = f"Model {variant}" + ("" if bushing is None else " with bushings")
    with StageProgress(what, ["bodies", "assembly", "linearisation", "system modes"]) as progress:
        progress.stage("bodies")  # from the cache, or built (a bar of its own)
        model = build_model(variant, damping=damping, mesh_size=mesh, bushing=bushing, exudyn_mesh="used")
        progress.stage("assembly")
        model.assemble()
        progress.stage("linearisation")
        system = linearise(model)
        progress.stage("system modes")
        modes = system_modes(model, system, max_frequency_hz=max_frequency_hz, n_modes=N_MODES)
    return model, modes


def save_table(modes, out: Path, stem: str, title: str) -> str:
    """Print and save the mode table (markdown and CSV); returns the markdown."""
    from exudyn_study.linear.modes import modes_table

    md = f"# {title}\n\n" + modes_table(modes, "markdown") + "\n"
    (out / f"{stem}_modes.md").write_text(md)
    with open(out / f"{stem}_modes.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["mode", "undamped_frequency_hz", "frequency_hz", "damping_ratio_percent", "description"])
        for j in range(modes.frequency_hz.size):
            fu = modes.undamped_frequency_hz[j] if j < modes.undamped_frequency_hz.size else float("nan")
            w.writerow([j + 1, f"{fu:.4f}", f"{modes.frequency_hz[j]:.4f}",
                        f"{100 * modes.damping_ratio[j]:.4f}", modes.descriptions[j]])
    print(title)
    print(modes_table(modes))
    return md


def plot_shapes(modes, path: Path, title: str) -> None:
    """Mode shapes at the sensors: one panel per mode, signed magnitude per channel."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = modes.frequency_hz.size
    names = list(modes.sensor_names)
    fig, axes = plt.subplots(n, 1, figsize=(14, 1.6 * n + 1), sharex=True)
    axes = np.atleast_1d(axes)
    for j, ax in enumerate(axes):
        s = modes.shapes[:, j]
        # real shape with sign: rotate so the largest component is real, then take the real part
        s = (s * np.exp(-1j * np.angle(s[np.argmax(np.abs(s))]))).real
        colors = ["tab:blue" if nm.endswith("Z") else "tab:orange" if nm.endswith("Y") else "tab:green"
                  for nm in names]
        ax.bar(range(len(names)), s, color=colors)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylim(-1.1, 1.1)
        ax.set_ylabel(f"{modes.frequency_hz[j]:.1f} Hz", rotation=0, ha="right", va="center", fontsize=8)
        ax.text(0.99, 0.85, modes.descriptions[j], transform=ax.transAxes, ha="right", fontsize=7)
        ax.set_yticks([])
    axes[-1].set_xticks(range(len(names)))
    axes[-1].set_xticklabels(names, rotation=90, fontsize=7)
    fig.suptitle(f"{title} - mode shapes at the sensors (Z blue, Y orange, X green)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def run(variant: int, argv=None, title: str | None = None) -> tuple:
    """Command-line entry shared by the three model studies."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mesh", default="production")
    p.add_argument("--damping", default="adams-default")
    p.add_argument("--out", default="results/studies")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    print(f"Model {variant} ({args.mesh} mesh, damping {args.damping}): bodies, assembly, linearisation, "
          f"first {N_MODES} system modes", flush=True)
    model, modes = modes_of(variant, args.damping, args.mesh)
    title = title or (f"Model {variant} ({args.mesh} mesh, damping {args.damping}): "
                      f"first {N_MODES} system modes")
    save_table(modes, out, f"model{variant}", title)
    plot_shapes(modes, out / f"model{variant}_shapes.png", f"Model {variant}")
    print(f"built, linearised and solved in {time.perf_counter() - t0:.0f} s; "
          f"written to {out}/model{variant}_*")
    return model, modes, args


if __name__ == "__main__":
    run(1)
