"""Study: Model 3 on the rig (frame, two tanks, two brackets as separate flexible bodies).

The analogue of the thesis's Table 4 (first ten system modes, components joined by fixed
joints) and the mode shapes at the sensors; then the same with the 6-DOF bushing element
(:class:`exudyn_study.model.BushingParameters`, defaults) instead of fixed joints, and the
comparison with Model 1: modes paired by MAC at the 42 sensors, frequency of Model 1,
Model 3 fixed and Model 3 bushing. The thesis observed Model 3's component-dominated
modes higher than Model 1's with fixed joints; a compliant bushing should move them down.

``python studies/model3.py [--mesh production] [--damping adams-default] [--out DIR]``
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from model1 import modes_of, plot_shapes, run, save_table  # noqa: E402


def compare(m1, m3, m3b) -> str:
    """Markdown table: Model 3 modes (fixed) with their Model 1 and bushing partners (MAC pairing)."""
    from exudyn_study.linear.modes import to_modal_model
    from exudyn_study.linear.pairing import pair_modal_models

    mm1, mm3, mm3b = (to_modal_model(m) for m in (m1, m3, m3b))
    p1 = {p.reference_index: p for p in pair_modal_models(mm1, mm3, min_mac=0.5, max_frequency_error=0.5)}
    pb = {p.reference_index: p for p in pair_modal_models(mm3b, mm3, min_mac=0.5, max_frequency_error=0.5)}
    lines = ["| Model 3 mode | Description (Model 3, fixed) | Model 1 f (Hz) [MAC] | Model 3 fixed f (Hz) | "
             "change vs Model 1 | Model 3 bushing f (Hz) [MAC] | change fixed -> bushing |",
             "|---|---|---|---|---|---|---|"]
    for j in range(m3.frequency_hz.size):
        f3 = m3.frequency_hz[j]
        a = p1.get(j)
        b = pb.get(j)
        c1 = f"{m1.frequency_hz[a.model_index]:.2f} [{a.mac:.2f}]" if a else "-"
        d1 = f"{100 * (f3 / m1.frequency_hz[a.model_index] - 1):+.1f} %" if a else "-"
        cb = f"{m3b.frequency_hz[b.model_index]:.2f} [{b.mac:.2f}]" if b else "-"
        db = f"{100 * (m3b.frequency_hz[b.model_index] / f3 - 1):+.1f} %" if b else "-"
        lines.append(f"| {j + 1} | {m3.descriptions[j]} | {c1} | {f3:.2f} | {d1} | {cb} | {db} |")
    return "\n".join(lines)


if __name__ == "__main__":
    from exudyn_study.model import BushingParameters

    model3, modes3, args = run(3)
    out = Path(args.out)
    _, modes3b = modes_of(3, args.damping, args.mesh, bushing=BushingParameters())
    save_table(modes3b, out, "model3_bushing",
               f"Model 3 with 6-DOF bushings ({args.mesh} mesh, damping {args.damping}): "
               "first 10 system modes")
    plot_shapes(modes3b, out / "model3_bushing_shapes.png", "Model 3, bushings")
    _, modes1 = modes_of(1, args.damping, args.mesh)
    table = compare(modes1, modes3, modes3b)
    heading = "# Model 3 (fixed joints, bushings) vs Model 1, modes paired by MAC at the sensors"
    text = heading + "\n\n" + table + "\n"
    (out / "model3_vs_model1.md").write_text(text)
    print(text)
