"""Figures of an identification (matplotlib, Agg backend, written to files).

- :func:`plot_stabilisation`: stabilisation diagram over the sum of FRF magnitudes
  (like thesis Figure 2),
- :func:`plot_frf_fit`: measured versus synthesised FRFs per channel,
- :func:`plot_mac`: a MAC matrix,
- :func:`plot_mode_shapes`: mode shapes at the sensor positions,
- :func:`plot_all`: all of the above for an
  :class:`~exudyn_study.identify.pipeline.IdentificationResult`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = ["plot_stabilisation", "plot_frf_fit", "plot_mac", "plot_mode_shapes", "plot_all"]


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path) -> Path:
    path = Path(path)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    _plt().close(fig)
    return path


def _plain_log_ticks(axis) -> None:
    """Label a log axis with plain numbers (1, 2, 5, 10, 20, ...), never ``2x10^1``."""
    from matplotlib import ticker

    axis.set_major_locator(ticker.LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(ticker.NullFormatter())


def plot_stabilisation(result, path: str | os.PathLike) -> Path:
    """Stabilisation diagram over the sum of FRFs.

    Parameters
    ----------
    result : IdentificationResult
        Identification result (poles, FRFs, selection, band).
    path : str or path-like
        PNG file to write.

    Returns
    -------
    Path
    """
    plt = _plt()
    p = result.poles
    frf = result.frf
    lo, hi = result.band_hz
    sel = (frf.freq_hz >= lo) & (frf.freq_hz <= hi)
    fig, ax = plt.subplots(figsize=(11, 6))
    sym = p.symbol
    styles = {
        "o": dict(marker="o", s=10, facecolors="none", edgecolors="0.75", label="new"),
        "f": dict(marker="x", s=14, c="tab:blue", label="stable frequency"),
        "d": dict(marker="d", s=14, facecolors="none", edgecolors="tab:green",
                  label="+ damping"),
        "v": dict(marker="v", s=14, facecolors="none", edgecolors="tab:purple",
                  label="+ vector"),
        "s": dict(marker="s", s=16, c="tab:red", label="stable (f, d, v)"),
    }
    for key, st in styles.items():
        m = sym == key
        if m.any():
            ax.scatter(p.frequency_hz[m], p.order[m], linewidths=0.8, zorder=3, **st)
    for mode in result.model.modes:
        ax.axvline(mode.frequency_hz, color="k", lw=0.6, ls="--", zorder=1)
    ax.set_xlim(lo, hi)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("model order")
    ax.set_ylim(0, max(p.orders) + 2)
    ax2 = ax.twinx()
    total = np.sum(np.abs(frf.H[:, :, sel]), axis=(0, 1))
    ax2.semilogy(frf.freq_hz[sel], total, color="tab:red", lw=1.0, alpha=0.8, zorder=2)
    ax2.set_ylabel("sum of |H| over channels [-]")
    _plain_log_ticks(ax2.yaxis)
    ax.set_zorder(ax2.get_zorder() + 1)
    ax.patch.set_visible(False)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=5, fontsize=8,
              frameon=False)
    refs = ", ".join(frf.inputs) if frf.inputs else "reference"
    ax.set_title(
        f"Stabilisation diagram ({frf.estimator}, {frf.resolution_hz:g} Hz, ref. {refs}): "
        f"{len(result.model)} modes selected (dashed)"
    )
    return _save(fig, path)


def plot_frf_fit(result, path: str | os.PathLike, channels: Sequence[str] | None = None,
                 max_channels: int = 12) -> Path:
    """Measured versus synthesised FRF magnitude per channel.

    Without ``channels``, the ``max_channels`` channels with the largest fit error are shown
    (where a missing or wrong mode shows first), and the title says how many of how many.
    The fit error is ``||H_measured - H_synthesised|| / ||H_measured||`` over the band.

    Parameters
    ----------
    result : IdentificationResult
        Identification result with a fit.
    path : str or path-like
        PNG file to write.
    channels : sequence of str, optional
        Channels to show (default: the worst-fitting ``max_channels``).
    max_channels : int, optional
        Maximum number of panels (default 12).

    Returns
    -------
    Path
    """
    plt = _plt()
    frf, fit = result.frf, result.fit
    names = list(frf.outputs) or [f"ch{i}" for i in range(frf.H.shape[0])]
    if channels:
        idx = [names.index(c) for c in channels]
        which = f"{min(len(idx), max_channels)} chosen channels"
    elif fit is not None:
        idx = list(np.argsort(-np.asarray(fit.fit_error))[: min(max_channels, len(names))])
        which = (f"all {len(names)} channels" if len(idx) == len(names)
                 else f"the {len(idx)} of {len(names)} channels with the largest fit error")
    else:
        idx = list(range(len(names)))
        which = f"{min(len(idx), max_channels)} of {len(names)} channels"
    idx = idx[:max_channels]
    lo, hi = result.band_hz
    sel = (frf.freq_hz >= lo) & (frf.freq_hz <= hi)
    ncol = 3
    nrow = int(np.ceil(len(idx) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(13, 2.6 * nrow + 0.6), squeeze=False, sharex=True)
    for ax, i in zip(axes.ravel(), idx, strict=False):
        # a wide light line under a thin dark dashed one: both stay visible where they agree
        ax.semilogy(frf.freq_hz[sel], np.abs(frf.H[i, 0, sel]), color="tab:red", lw=2.2, alpha=0.55,
                    label="measured")
        if fit is not None:
            ax.semilogy(fit.freq_hz, np.abs(fit.synthesised[i, 0]), color="k", lw=0.9, ls="--",
                        label="synthesised")
            ax.set_title(f"{names[i]}: fit error {100 * fit.fit_error[i]:.1f} %", fontsize=9)
        else:
            ax.set_title(names[i], fontsize=9)
        _plain_log_ticks(ax.yaxis)
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes.ravel()[len(idx):]:
        ax.set_visible(False)
    axes[0, 0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("frequency [Hz]")
    for ax in axes[:, 0]:
        ax.set_ylabel("|H| [-]")
    ref = result.frf.inputs[0] if result.frf.inputs else "the reference"
    fig.suptitle(f"Measured ({result.frf.estimator}) vs synthesised FRFs to {ref}: {which}\n"
                 "fit error = ||H_measured - H_synthesised|| / ||H_measured|| over "
                 f"{lo:g}-{hi:g} Hz", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def plot_mac(matrix: np.ndarray, path: str | os.PathLike, *,
             row_labels: Sequence[str] | None = None, col_labels: Sequence[str] | None = None,
             title: str = "MAC", row_title: str = "mode", col_title: str = "mode") -> Path:
    """Plot a MAC matrix as a colour map with values.

    Parameters
    ----------
    matrix : ndarray, shape (n_a, n_b)
        MAC values in [0, 1].
    path : str or path-like
        PNG file to write.
    row_labels, col_labels : sequence of str, optional
        Tick labels (e.g. frequencies).
    title : str, optional
        Figure title.
    row_title, col_title : str, optional
        Axis labels (what the rows and columns are, e.g. ``"mode frequency [Hz]"``).

    Returns
    -------
    Path
    """
    plt = _plt()
    m = np.asarray(matrix, float)
    fig, ax = plt.subplots(figsize=(1.0 + 0.6 * m.shape[1], 0.8 + 0.6 * m.shape[0]))
    im = ax.imshow(m, vmin=0, vmax=1, cmap="viridis")
    for (i, j), v in np.ndenumerate(m):
        ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=7,
                color="w" if v < 0.6 else "k")
    ax.set_xticks(range(m.shape[1]), col_labels or range(1, m.shape[1] + 1), rotation=90,
                  fontsize=8)
    ax.set_yticks(range(m.shape[0]), row_labels or range(1, m.shape[0] + 1), fontsize=8)
    ax.set_xlabel(col_title)
    ax.set_ylabel(row_title)
    fig.colorbar(im, ax=ax, label="MAC [-]")
    ax.set_title(title)
    return _save(fig, path)


def _sensor_nodes(names, positions_m, directions, tol_m: float = 1e-3):
    """Group channels at one point into a node: node positions, each channel's node and direction."""
    unit = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}
    nodes: list[np.ndarray] = []
    node_of = np.empty(len(names), int)
    for i, n in enumerate(names):
        p = np.asarray(positions_m[n], float)
        hit = [k for k, q in enumerate(nodes) if np.linalg.norm(q - p) <= tol_m]
        if hit:
            node_of[i] = hit[0]
        else:
            node_of[i] = len(nodes)
            nodes.append(p)
    dirs = np.array([unit[directions[n]] for n in names]).reshape(-1, 3)
    return np.array(nodes).reshape(-1, 3), node_of, dirs


def _wire_frame(nodes: np.ndarray) -> list[tuple[int, int]]:
    """Edges of a wire frame through the nodes: their Euclidean minimum spanning tree."""
    from scipy.sparse.csgraph import minimum_spanning_tree
    from scipy.spatial.distance import cdist

    if len(nodes) < 2:
        return []
    tree = minimum_spanning_tree(cdist(nodes, nodes)).tocoo()
    return list(zip(tree.row.tolist(), tree.col.tolist(), strict=True))


def _real_shape(v: np.ndarray) -> np.ndarray:
    """Rotate a complex shape to its best real direction, take the real part, largest entry 1."""
    c = np.array([[v.real @ v.real, v.real @ v.imag], [v.real @ v.imag, v.imag @ v.imag]])
    _, e = np.linalg.eigh(c)
    r = (v * np.exp(-1j * np.arctan2(e[1, -1], e[0, -1]))).real
    return r / max(np.abs(r).max(), 1e-30)


def plot_mode_shapes(model, positions_m: Mapping[str, Sequence[float]],
                     directions: Mapping[str, str], path: str | os.PathLike,
                     scale: float = 0.15) -> Path:
    """Mode shapes on a wire frame through the sensor positions (3-D, one panel per mode).

    Channels at one point form a node; the wire frame joins the nodes by their minimum
    spanning tree (the layout has no measured connectivity). Each mode is rotated to its
    best real direction and its largest coefficient scaled to ``scale`` times the size of
    the layout; the undeformed frame is drawn grey, the deformed one in colour, on the same
    axes limits in every panel, so panels compare directly.

    Parameters
    ----------
    model : ModalModel
        Identified modes.
    positions_m : mapping str -> (x, y, z)
        Sensor positions in m.
    directions : mapping str -> {'X', 'Y', 'Z'}
        Measuring directions.
    path : str or path-like
        PNG file to write.
    scale : float, optional
        Displacement of the largest coefficient relative to the layout size.

    Returns
    -------
    Path
    """
    plt = _plt()
    names = [n for n in model.channels if n in positions_m and directions.get(n) in "XYZ"
             and directions.get(n)]
    nodes, node_of, dirs = _sensor_nodes(names, positions_m, directions)
    edges = _wire_frame(nodes)
    size = float(np.ptp(nodes, axis=0).max()) if len(nodes) else 1.0
    deformed = []
    for mode in model.modes:
        r = _real_shape(mode.shape_vector(names))
        disp = np.zeros_like(nodes)
        np.add.at(disp, node_of, r[:, None] * dirs)
        deformed.append(nodes + scale * size * disp)
    allp = np.vstack([nodes, *deformed]) if deformed else nodes
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.05 * size
    lo, hi = lo - pad, hi + pad
    n_modes = len(model)
    ncol = min(3, max(1, n_modes))
    nrow = int(np.ceil(max(n_modes, 1) / ncol))
    fig = plt.figure(figsize=(6.0 * ncol, 4.6 * nrow))
    for k, (mode, moved) in enumerate(zip(model.modes, deformed, strict=True)):
        ax = fig.add_subplot(nrow, ncol, k + 1, projection="3d")
        for i, j in edges:
            ax.plot(*nodes[[i, j]].T, color="0.55", lw=0.8)
            ax.plot(*moved[[i, j]].T, color="tab:blue", lw=1.4)
        ax.scatter(*moved.T, s=8, c="tab:red", depthshade=False)
        ax.set_title(f"mode {k + 1}: {mode.frequency_hz:.2f} Hz, {100 * mode.damping_ratio:.2f} %",
                     fontsize=9)
        for setter, label in ((ax.set_xlabel, "x [m]"), (ax.set_ylabel, "y [m]"), (ax.set_zlabel, "z [m]")):
            setter(label, fontsize=7, labelpad=-4)
        ax.tick_params(labelsize=6, pad=-2)
        ax.view_init(elev=25, azim=-60)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(hi - lo, zoom=1.25)
    fig.suptitle("Mode shapes at the sensors: grey undeformed, blue deformed, red the sensors "
                 f"(largest motion {scale:g} x "
                 f"the {size:.2f} m layout, the same scale in every panel)", fontsize=10)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.97))
    return _save(fig, path)


def plot_all(result, directory: str | os.PathLike, *,
             positions_m: Mapping[str, Sequence[float]] | None = None,
             directions: Mapping[str, str] | None = None) -> list[Path]:
    """Write all figures of ``result`` into ``directory`` (created if missing).

    Parameters
    ----------
    result : IdentificationResult
        Identification result.
    directory : str or path-like
        Output directory.
    positions_m, directions : mapping, optional
        Sensor positions (m) and directions for the mode-shape figure (skipped
        without them).

    Returns
    -------
    list of Path
        The files written: stabilisation.png, frf_fit.png, automac.png and
        mode_shapes.png (the last two only when modes were found).
    """
    from exudyn_study.identify.mac import automac

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    out = [plot_stabilisation(result, d / "stabilisation.png")]
    if result.fit is not None and len(result.model):
        out.append(plot_frf_fit(result, d / "frf_fit.png"))
        labels = [f"{m.frequency_hz:.2f}" for m in result.model.modes]
        out.append(plot_mac(automac(result.model.shapes()), d / "automac.png",
                            row_labels=labels, col_labels=labels,
                            title="AutoMAC of the identified modes", row_title="mode frequency [Hz]",
                            col_title="mode frequency [Hz]"))
        if positions_m and directions:
            out.append(plot_mode_shapes(result.model, positions_m, directions,
                                        d / "mode_shapes.png"))
    return out
