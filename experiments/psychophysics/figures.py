"""Matplotlib figures of a flash-localization table (PNG and SVG).

* ``fig11``: true vs perceived positions with error vectors, one panel per saccade amplitude,
  for flashes near saccade onset (the paper's Fig. 11; Lappe et al. 2000).
* ``perceived_vs_time``: perceived horizontal position vs flash time, one curve per flash
  column (Morrone, Ross & Burr 1997, Fig. 2 style).
* ``compression_vs_time``: compression index vs flash time per amplitude, with the
  closed-form 1 - e^{-g(t)} of the time course.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..folders import save_figure
from .analysis import compression_index
from .timecourse import RemapTimeCourse

__all__ = ["fig11", "perceived_vs_time", "compression_vs_time", "save_all"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, out: Path, name: str, formats: tuple[str, ...]) -> list[Path]:
    paths = []
    for ext in formats:
        p = out / f"{name}.{ext}"
        save_figure(fig, p, dpi=120, close=False, bbox_inches="tight")
        paths.append(p)
    _plt().close(fig)
    return paths


def fig11(table: dict[str, np.ndarray], window_ms: float = 25.0):
    """True (open) and perceived (filled) positions with error vectors for |t_flash| <= window_ms."""
    plt = _plt()
    amps = np.unique(table["saccade_amplitude_deg"])
    fig, axes = plt.subplots(len(amps), 1, figsize=(7, 2.6 * len(amps)), squeeze=False, sharex=True)
    for ax, a in zip(axes[:, 0], amps):
        m = (table["saccade_amplitude_deg"] == a) & (np.abs(table["flash_time_ms"]) <= window_ms)
        tx, ty = table["true_x_deg"][m], table["true_y_deg"][m]
        px, py = table["perceived_x_deg"][m], table["perceived_y_deg"][m]
        ax.quiver(tx, ty, px - tx, py - ty, angles="xy", scale_units="xy", scale=1, width=0.003, color="0.3")
        ax.scatter(tx, ty, facecolors="none", edgecolors="tab:green", s=25, label="flash (true)")
        ax.scatter(px, py, color="tab:purple", s=12, label="perceived")
        ax.plot([-a / 2], [0], "o", color="tab:red", label="fixation")
        ax.plot([a / 2], [0], "*", color="gold", markeredgecolor="k", ms=12, label="saccade target")
        ax.annotate(
            "", xy=(a / 2 - 1, -8.5), xytext=(-a / 2 + 1, -8.5), arrowprops=dict(arrowstyle="->", color="tab:red")
        )
        ax.set_ylim(-9.5, 9.5)
        ax.set_aspect("equal")
        ax.set_ylabel("elevation (deg)")
        ax.set_title(f"{a:g} deg saccade, flashes {-window_ms:+.0f}..{window_ms:+.0f} ms re onset", fontsize=9)
    axes[-1, 0].set_xlabel("azimuth (deg, head-centred)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=4, bbox_to_anchor=(0.5, -0.01))
    fig.suptitle("Perisaccadic compression towards the saccade target (cf. paper Fig. 11)", fontsize=10)
    fig.tight_layout(rect=(0, 0.03, 1, 0.98))
    return fig


def perceived_vs_time(table: dict[str, np.ndarray], amplitude_deg: float | None = None):
    """Perceived azimuth vs flash time for each flash column (dashed: true azimuth, dotted: target)."""
    plt = _plt()
    amps = np.unique(table["saccade_amplitude_deg"])
    a = float(amps[np.argmin(np.abs(amps - 20))]) if amplitude_deg is None else float(amplitude_deg)
    m = table["saccade_amplitude_deg"] == a
    fig, ax = plt.subplots(figsize=(6, 4.2))
    cols = np.unique(table["flash_dx_deg"][m])
    cmap = plt.get_cmap("coolwarm")
    for i, dx in enumerate(cols):
        mm = m & (table["flash_dx_deg"] == dx)
        times = np.unique(table["flash_time_ms"][mm])
        px = [table["perceived_x_deg"][mm & (table["flash_time_ms"] == s)].mean() for s in times]
        c = cmap(i / max(len(cols) - 1, 1))
        ax.plot(times, px, "o-", color=c, ms=3, label=f"flash at {a / 2 + dx:+g} deg")
        ax.axhline(a / 2 + dx, color=c, ls="--", lw=0.7)
    ax.axhline(a / 2, color="k", ls=":", lw=1, label="saccade target")
    ax.axvline(0, color="0.6", lw=0.8)
    ax.set_xlabel("flash time re saccade onset (ms)")
    ax.set_ylabel("perceived azimuth (deg)")
    ax.set_title(f"Perceived position vs flash time ({a:g} deg saccade)", fontsize=10)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1, 0.5))
    return fig


def compression_vs_time(table: dict[str, np.ndarray], timecourse: RemapTimeCourse | None = None):
    """Compression index vs flash time per amplitude, with the time course's closed form."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    for a, (times, ci) in compression_index(table).items():
        ax.plot(times, ci, "o-", ms=3, label=f"{a:g} deg")
    if timecourse is not None:
        t = np.linspace(-150, 150, 301)
        ax.plot(t, timecourse.compression(t), "k--", lw=1, label="1 - exp(-g(t))")
    ax.axvline(0, color="0.6", lw=0.8)
    ax.axhline(0, color="0.6", lw=0.8)
    ax.set_xlabel("flash time re saccade onset (ms)")
    ax.set_ylabel("compression index")
    ax.set_title("Compression index = 1 - perceived spread / true spread", fontsize=10)
    ax.legend(fontsize=8)
    return fig


def save_all(
    table: dict[str, np.ndarray],
    out_dir: str | Path,
    timecourse: RemapTimeCourse | None = None,
    formats: tuple[str, ...] = ("png", "svg"),
) -> list[Path]:
    """Write fig11, perceived_vs_time and compression_vs_time into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = _save(fig11(table), out, "fig11", formats)
    paths += _save(perceived_vs_time(table), out, "perceived_vs_time", formats)
    paths += _save(compression_vs_time(table, timecourse), out, "compression_vs_time", formats)
    return paths


def psychometric(table: dict[str, np.ndarray]):
    """Displacement paradigm: proportion of "forward" reports vs the target's step, per blank, with
    the fitted cumulative Gaussians (``analysis.displacement_psychometrics``)."""
    from scipy.stats import norm

    from .analysis import displacement_psychometrics

    fig, ax = _plt().subplots(figsize=(5.5, 3.8))
    for b, r in displacement_psychometrics(table).items():
        (line,) = ax.plot(
            r["steps_deg"], r["p_forward"], "o", label=f"blank {b} ms: threshold {r['threshold_deg']:.2f} deg"
        )
        xs = np.linspace(r["steps_deg"].min(), r["steps_deg"].max(), 200)
        ax.plot(xs, 0.01 + 0.98 * norm.cdf((xs - r["pse_deg"]) / r["threshold_deg"]), color=line.get_color())
    ax.set(
        xlabel="target step during the saccade (deg, + = forward)",
        ylabel='P("forward")',
        title="saccadic suppression of displacement",
        ylim=(-0.03, 1.03),
    )
    ax.axvline(0, color="0.7", lw=0.8)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def save_displacement(
    table: dict[str, np.ndarray], out_dir: str | Path, formats: tuple[str, ...] = ("png", "svg")
) -> list[Path]:
    """Write the displacement paradigm's psychometric functions into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return _save(psychometric(table), out, "psychometric", formats)
