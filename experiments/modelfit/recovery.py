"""``python -m experiments recovery``: can the theories be told apart from data of a realistic size?

Model recovery (Wagenmakers et al. 2004; Wilson & Collins 2019, eLife 8:e49547, "Ten simple rules
for the computational modeling of behavioral data", rule 6): for every generating model G (the
theories ``observer``, ``population`` and the seed's ``paper``), a localization data set is
simulated at G's defaults -- a few hundred reports: the design's trials in the references and
dark conditions, ``--reports`` noisy reports each (Gaussian report noise ``--noise-deg``) -- from
saccades with motor noise (``endpoint_noise`` 0.05, each trial its own draw). Every candidate
model F is then fitted to it by maximum likelihood (``compare``: its free parameters and the
report noise), through a forward model *without* that motor noise: no fitted model, not even G,
reads out the observations the data came from, so each is misspecified in its noise as a model
of real data would be. ``recovery.csv`` has one row per (generating, fitted) pair: the
log-likelihood, the AIC, ``delta_aic`` (AIC minus the best AIC for that data set: 0 for the
winner) and whether the winner is the generating model; ``recovery.png`` is the confusion
matrix. Each data set's fits live in ``DIR/<G>/`` (``compare``'s folder: resumable, each fit a
no-op when finished).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..folders import save_figure

__all__ = ["recover", "GENERATING"]

#: The models that generate data and are fitted.
GENERATING = ("observer", "population", "paper")
MOTOR_NOISE = 0.05  # saccade endpoint s.d., fraction of amplitude (van Beers 2007: ~5-10 %)


def _design(size: str):
    from ..psychophysics import MORRONE_OFFSETS_DEG, Design

    if size == "small":  # for tests: 4 flashes x 3 times
        return Design(
            amplitudes_deg=(20.0,),
            flash_offsets_deg=MORRONE_OFFSETS_DEG[:4],
            flash_times_ms=(-150, -25, 50),
            name="recovery-small",
        )
    return Design(
        amplitudes_deg=(20.0,),
        flash_offsets_deg=MORRONE_OFFSETS_DEG,
        flash_times_ms=(-150, -75, -50, -25, 0, 25, 50, 100),
        name="recovery",
    )


def recover(
    out: Path,
    models=GENERATING,
    *,
    size: str = "default",
    reports: int = 2,
    noise_deg: float = 1.5,
    image_size: int = 128,
    max_evals: int = 120,
    workers: int = 1,
    seed: int = 0,
    progress: bool = False,
    backend: str = "local",
    ray_address: str | None = None,
) -> list[dict]:
    """Simulate from each model, fit every model to each data set; write and return the rows.
    ``workers``, ``backend``, ``ray_address``: where the trials are observed (``backends``)."""
    from ..folders import write_csv
    from ..psychophysics import TrialConfig
    from .data import DataConventionWarning, read_data
    from .fitting import compare, simulate_data
    from .forward import forward_model
    from .likelihood import FIT_MODELS

    design = _design(size)
    config = TrialConfig(image_size=image_size, endpoint_noise=MOTOR_NOISE)
    rows = []
    for g, gen in enumerate(models):
        folder = out / gen
        folder.mkdir(parents=True, exist_ok=True)
        csv_path = folder / "data.csv"
        values = {p.name: p.default for p in FIT_MODELS[gen].parameters}
        values.update(noise_x_deg=noise_deg, noise_y_deg=noise_deg)
        if not csv_path.is_file() or not csv_path.with_suffix(".json").is_file():
            simulate_data(
                gen,
                values,
                design,
                reports=reports,
                seed=seed + g,
                out_csv=csv_path,
                workers=workers,
                config=config,
                progress=progress,
                backend=backend,
                ray_address=ray_address,
                meta={"recovery": "generated at the model's defaults with motor noise"},
            )
        with warnings.catch_warnings():
            # the data are this run's own simulation, in the format's conventions; the convention
            # heuristics (e.g. perceived falling as true rises: compression) would only alarm the user
            warnings.simplefilter("ignore", DataConventionWarning)
            data = read_data(csv_path)
        # the fits' forward model leaves out the motor noise by design (no note about an override)
        fwd = forward_model(data, {"endpoint_noise": 0.0}, note=False)
        fits = compare(
            data,
            list(models),
            folder / "fits",
            workers=workers,
            max_evals=max_evals,
            forward=fwd,
            progress=progress,
            backend=backend,
            ray_address=ray_address,
        )
        best = min(fits, key=lambda r: r["aic"])["model"]
        for r in fits:
            rows.append(
                {
                    "generating": gen,
                    "fitted": r["model"],
                    "log_likelihood": round(r["log_likelihood"], 3),
                    "n_parameters": r["n_parameters"],
                    "n": r["n"],
                    "aic": round(r["aic"], 3),
                    "delta_aic": round(r["delta_aic"], 3),
                    "winner": r["model"] == best,
                    "recovered": best == gen,
                }
            )
    write_csv(
        out / "recovery.csv",
        ["generating", "fitted", "log_likelihood", "n_parameters", "n", "aic", "delta_aic", "winner", "recovered"],
        rows,
    )
    _plot(rows, list(models), out / "recovery.png")
    return rows


def _plot(rows: list[dict], models: list[str], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = np.full((len(models), len(models)), np.nan)
    for r in rows:
        m[models.index(r["generating"]), models.index(r["fitted"])] = r["delta_aic"]
    fig, ax = plt.subplots(figsize=(1.6 + 1.3 * len(models), 1.2 + 1.1 * len(models)))
    im = ax.imshow(np.log10(1 + m), cmap="viridis_r")
    for i in range(len(models)):
        for j in range(len(models)):
            ax.text(j, i, f"{m[i, j]:.0f}", ha="center", va="center", color="w" if m[i, j] > 10 else "k")
    ax.set_xticks(range(len(models)), models)
    ax.set_yticks(range(len(models)), models)
    ax.set(xlabel="fitted model", ylabel="generating model", title="model recovery: AIC - best AIC (0 = chosen)")
    fig.colorbar(im, ax=ax, label="log10(1 + delta AIC)")
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
