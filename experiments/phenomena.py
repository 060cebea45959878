"""``python -m experiments phenomena``: which published perisaccadic phenomena each model reproduces.

For each perception model (``mechanistic``, ``paper``) small designs run through the rendered
pipeline (``experiments.psychophysics.run_trials``: resumable, one folder per design under
``DIR/tables/``), and each phenomenon is scored against its published description:

=================================  ==================================================================
phenomenon                         test (20 deg saccades unless said; "near onset": |t| <= 25 ms)
=================================  ==================================================================
compression_near_onset             peak compression index > 0.3 within 25 ms of onset, with references
                                   (Morrone, Ross & Burr 1997; Ross, Morrone & Burr 1997: ~50 %)
shift_in_dark                      in the dark, flashes 50 ms before onset shifted > 1 deg in the
                                   saccade's direction relative to -150 ms (Honda 1991; Lappe,
                                   Awater & Krekelberg 2000; Dassonville et al. 1992)
compression_needs_references       compression near onset with references exceeds the dark's by > 0.2
                                   (Lappe et al. 2000; Awater & Lappe 2006)
compression_grows_with_amplitude   24 deg saccades compress > 0.1 more than 12 deg near onset
                                   (Lavergne et al. 2010; Ostendorf et al. 2007)
anisotropic_compression            compression along the saccade exceeds that across it by > 0.1
                                   (Kaiser & Lappe 2004; Hamker et al. 2008)
separation_less_than_localization  two simultaneous flashes' separation compresses < half as much as
                                   their positions do (Reeve, Clark & O'Regan 2008, as cited by the
                                   issue that asked for this report)
displacement_suppression           the threshold for reporting an intrasaccadic target step's direction
                                   is > 2x higher without a post-saccadic blank than with a 250 ms one
                                   (Bridgeman, Hendry & Stark 1975; Deubel, Schneider & Bridgeman 1996)
=================================  ==================================================================

Writes ``phenomena.csv`` (``phenomenon, model, published, simulated, reproduced``: ``yes``, ``no``
or ``not tested``), ``phenomena.txt`` (the same as a table) and one figure per phenomenon. The
eyes are 128 px (faster; the retina's sampling error is larger than at the study's 256 px, and
the tests compare within a design so that it largely cancels). About a minute on 2 cores.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .cli import out_dir

__all__ = ["add_subcommand", "PHENOMENA", "measure", "score"]

OFFSETS = ((-8.0, 3.0), (8.0, -3.0), (-4.0, -6.0), (4.0, 6.0), (-12.0, 3.0), (2.0, -4.0), (6.0, 0.0), (-6.0, 0.0))
TIMES = (-150, -100, -50, -25, 0, 25, 50, 100, 150)
IMAGE_SIZE = 128
MODELS = ("mechanistic", "paper")

PUBLISHED = {
    "compression_near_onset": "compression towards the target peaks near onset, ~50 % (Morrone et al. 1997)",
    "shift_in_dark": "in darkness flashes before the saccade shift in its direction (Honda 1991; Lappe et al. 2000)",
    "compression_needs_references": "compression needs post-saccadic references (Lappe et al. 2000; Awater & Lappe 2006)",
    "compression_grows_with_amplitude": "compression grows with saccade amplitude (Lavergne et al. 2010)",
    "anisotropic_compression": "2-D compression, stronger along the saccade (Kaiser & Lappe 2004; Hamker et al. 2008)",
    "separation_less_than_localization": "perceived separation compresses much less than localization (Reeve et al. 2008)",
    "displacement_suppression": "intrasaccadic steps go unnoticed; a post-saccadic blank restores them "
                                "(Bridgeman et al. 1975; Deubel et al. 1996)",
}
PHENOMENA = tuple(PUBLISHED)


def _designs():
    from .psychophysics import Design

    d20 = Design(amplitudes_deg=(20.0,), flash_offsets_deg=OFFSETS, flash_times_ms=TIMES, name="phenomena20")
    amp = Design(amplitudes_deg=(12.0, 24.0), flash_offsets_deg=OFFSETS, flash_times_ms=(-25, 0, 25), name="amplitude")
    sep = Design(amplitudes_deg=(20.0,), flash_offsets_deg=OFFSETS, flash_times_ms=(-150, -25, 0, 25), name="separation")
    disp = Design(amplitudes_deg=(20.0,), flash_offsets_deg=tuple((s, 0.0) for s in (-4, -3, -2, -1, 0, 1, 2, 3, 4)),
                  flash_times_ms=(0, 250), repetitions=6, name="displacement")
    return {"references": (d20, dict(condition="references")), "dark": (d20, dict(condition="dark")),
            "amplitude": (amp, dict(condition="references")),
            "separation": (sep, dict(condition="references", paradigm="separation")),
            "displacement": (disp, dict(condition="dark", paradigm="displacement"))}


def measure(out: Path, models=MODELS, workers: int = 1, progress: bool = False) -> dict:
    """Run (or resume) every design for every model; returns {model: {design: table}}."""
    from .psychophysics import TrialConfig, read_table, run_trials

    tables = {}
    for model in models:
        tables[model] = {}
        for name, (design, kw) in _designs().items():
            cfg = TrialConfig(image_size=IMAGE_SIZE, model=model, **kw)
            csv_path = run_trials(design, cfg, out / "tables" / f"{model}_{name}", workers=workers, progress=progress)
            tables[model][name] = read_table(csv_path)
    return tables


def _ci_xy(t: dict, sel: np.ndarray) -> tuple[float, float]:
    """Compression along x and along y: 1 - perceived / true standard deviation, per axis."""
    px, py, tx, ty = (t[c][sel] for c in ("perceived_x_deg", "perceived_y_deg", "true_x_deg", "true_y_deg"))
    return 1 - px.std() / tx.std(), 1 - py.std() / ty.std()


def score(tables: dict) -> list[dict]:
    """One row per (phenomenon, model): published, simulated (a short measured statement), reproduced."""
    from .psychophysics import compression_index, displacement_psychometrics, separation_compression

    rows = []
    for model, tab in tables.items():
        ref, dark = tab["references"], tab["dark"]
        times, ci_ref = compression_index(ref)[20.0]
        _, ci_dark = compression_index(dark)[20.0]
        near = np.abs(times) <= 25
        i = int(np.argmax(ci_ref))
        res = {}
        res["compression_near_onset"] = (f"peak index {ci_ref[i]:.2f} at {times[i]:+.0f} ms",
                                         ci_ref[i] > 0.3 and abs(times[i]) <= 25)

        def mean_x(t, time):
            return float(t["error_x_deg"][t["flash_time_ms"] == time].mean())

        shift = mean_x(dark, -50) - mean_x(dark, -150)
        res["shift_in_dark"] = (f"{shift:+.2f} deg at -50 ms (re -150 ms), {mean_x(dark, -100) - mean_x(dark, -150):+.2f} "
                                f"at -100", shift > 1.0)
        diff = float(ci_ref[near].mean() - ci_dark[near].mean())
        res["compression_needs_references"] = (f"index near onset {ci_ref[near].mean():.2f} with references, "
                                               f"{ci_dark[near].mean():.2f} in the dark", diff > 0.2)
        ca = compression_index(tab["amplitude"])
        c12, c24 = float(ca[12.0][1].mean()), float(ca[24.0][1].mean())
        res["compression_grows_with_amplitude"] = (f"index near onset {c12:.2f} (12 deg), {c24:.2f} (24 deg)",
                                                   c24 > c12 + 0.1)
        sel = np.abs(ref["flash_time_ms"]) <= 25
        cx, cy = _ci_xy(ref, sel)
        res["anisotropic_compression"] = (f"along {cx:.2f}, across {cy:.2f} (near onset)", cx > cy + 0.1)
        sep = tab["separation"]
        st, sc = separation_compression(sep)[20.0]
        lt, lc = compression_index(sep)[20.0]
        nm = np.abs(st) <= 25
        s_m, l_m = float(sc[nm].mean()), float(lc[nm].mean())
        res["separation_less_than_localization"] = (f"separation {s_m:.2f}, localization {l_m:.2f} (near onset)",
                                                    s_m < 0.5 * l_m)
        fits = displacement_psychometrics(tab["displacement"])
        t0, t250 = fits[0]["threshold_deg"], fits[250]["threshold_deg"]
        res["displacement_suppression"] = (f"threshold {t0:.2f} deg without blank, {t250:.2f} with 250 ms",
                                           t0 > 2 * t250)
        for name in PHENOMENA:
            text, ok = res[name]
            rows.append({"phenomenon": name, "model": model, "published": PUBLISHED[name], "simulated": text,
                         "reproduced": "not tested" if ok is None else ("yes" if ok else "no")})
    return rows


def plot(tables: dict, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .psychophysics import compression_index, separation_compression

    paths = []

    def save(fig, name):
        p = out / f"{name}.png"
        fig.tight_layout()
        fig.savefig(p, dpi=100)
        plt.close(fig)
        paths.append(p)

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6), sharey=True)
    for k, model in enumerate(tables):
        for cond, style in (("references", "-o"), ("dark", "--s")):
            t, c = compression_index(tables[model][cond])[20.0]
            ax[k].plot(t, c, style, label=cond)
        ax[k].set(title=f"{model}: compression index, 20° saccade", xlabel="flash time re onset (ms)")
        ax[k].axhline(0, color="0.7", lw=0.8)
        ax[k].legend()
    ax[0].set_ylabel("1 - perceived / true spread")
    save(fig, "compression_near_onset_and_references")
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for model in tables:
        d = tables[model]["dark"]
        ts = np.unique(d["flash_time_ms"])
        ax.plot(ts, [d["error_x_deg"][d["flash_time_ms"] == s].mean() for s in ts], "-o", label=model)
    ax.axhline(0, color="0.7", lw=0.8)
    ax.set(title="dark: mean horizontal error (saccade goes +x)", xlabel="flash time re onset (ms)", ylabel="deg")
    ax.legend()
    save(fig, "shift_in_dark")
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for model in tables:
        ca = compression_index(tables[model]["amplitude"])
        ax.plot(sorted(ca), [ca[a][1].mean() for a in sorted(ca)], "-o", label=model)
    ax.set(title="compression near onset vs amplitude", xlabel="saccade amplitude (deg)", ylabel="compression index")
    ax.legend()
    save(fig, "compression_grows_with_amplitude")
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for k, model in enumerate(tables):
        r = tables[model]["references"]
        cx, cy = _ci_xy(r, np.abs(r["flash_time_ms"]) <= 25)
        ax.bar([k - 0.15, k + 0.15], [cx, cy], width=0.3, color=["C0", "C1"])
    ax.set_xticks(range(len(tables)), list(tables))
    ax.set(title="compression along (blue) and across (orange) the saccade", ylabel="1 - perceived / true s.d.")
    save(fig, "anisotropic_compression")
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for model in tables:
        s = tables[model]["separation"]
        st, sc = separation_compression(s)[20.0]
        lt, lc = compression_index(s)[20.0]
        line, = ax.plot(lt, lc, "-o", label=f"{model}: localization")
        ax.plot(st, sc, "--s", color=line.get_color(), label=f"{model}: separation")
    ax.set(title="two simultaneous flashes 4° apart", xlabel="flash time re onset (ms)", ylabel="compression")
    ax.legend(fontsize=8)
    save(fig, "separation_less_than_localization")
    from .psychophysics import displacement_psychometrics

    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for model in tables:
        for b, r in displacement_psychometrics(tables[model]["displacement"]).items():
            ax.plot(r["steps_deg"], r["p_forward"], "-o" if b == 0 else "--s",
                    label=f"{model}, blank {b} ms: {r['threshold_deg']:.2f}°")
    ax.set(title="target step during the saccade", xlabel="step (deg, + forward)", ylabel='P("forward")')
    ax.legend(fontsize=7)
    save(fig, "displacement_suppression")
    return paths


def _write(out: Path, tables: dict) -> tuple[str, list]:
    from .folders import atomic_write_text, write_csv

    rows = score(tables)
    write_csv(out / "phenomena.csv", ["phenomenon", "model", "published", "simulated", "reproduced"], rows)
    lines = [f"{'phenomenon':34s} {'model':12s} {'reproduced':11s} simulated"]
    lines += [f"{r['phenomenon']:34s} {r['model']:12s} {r['reproduced']:11s} {r['simulated']}" for r in rows]
    text = "\n".join(lines) + "\n"
    atomic_write_text(out / "phenomena.txt", text)
    return text, plot(tables, out)


def run(args: argparse.Namespace) -> int:
    """The command: one process per folder (a lock), interruptible and resumable, one-line errors."""
    from .cli import guarded
    from .psychophysics.runner import FolderBusyError, OutputFolderError, folder_lock, prepare_output_folder

    parser = getattr(args, "_parser", None)
    try:
        out = prepare_output_folder(args.out)
    except (OutputFolderError, TypeError) as e:
        if parser is None:
            raise
        parser.error(f"argument --out: {e}")

    def work() -> int:
        with folder_lock(out):
            tables = measure(out, workers=args.workers, progress=not args.no_progress)
            text, figures = _write(out, tables)
        print(text, end="")
        print(f"wrote {out / 'phenomena.csv'}, {out / 'phenomena.txt'} and {len(figures)} figures in {out}")
        return 0

    return guarded("python -m experiments phenomena", work,
                   resume_hint=f"the finished trials are kept in {out}/tables: run the same command again to resume",
                   # ValueError: e.g. a tables/ folder holding another configuration
                   errors={FolderBusyError: 1, ValueError: 2})


def add_subcommand(subparsers) -> None:
    """Register ``phenomena`` on the ``experiments`` command line."""
    p = subparsers.add_parser("phenomena", help="which published perisaccadic phenomena each perception model "
                                                "reproduces (table, figures)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=out_dir, default="results/phenomena",
                   help="output folder (created; its tables/ are resumed)")
    p.add_argument("--workers", type=int, choices=range(1, 17), default=1, metavar="N",
                   help="worker processes per design (1-16; 1 = in-process)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(func=run, _parser=p)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run(argparse.Namespace(out="results/phenomena", workers=1, no_progress=False)))
