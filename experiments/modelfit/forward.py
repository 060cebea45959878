"""The fit's forward model is the one that made the data: the observing configuration and the trials.

A fit re-runs every trial behind the data through the real pipeline, so it must render them as
they were rendered (image size, field of view, retina, saccade model, endpoint noise) and read
them out with the same fixed settings (threshold, latency, eye-position signal); only the fitted
parameters may differ. Where that configuration comes from, in order:

1. a sidecar beside the data file: ``run.json`` beside a ``trials.csv``/``trials.parquet`` written
   by ``python -m experiments run`` (checked against the table's ``config_hash`` column), or
   ``NAME.json`` beside ``NAME.csv`` written by ``python -m experiments simulate`` (its ``config``);
2. else the defaults of ``TrialConfig`` (those of ``run``: 256 px, 90 deg);
3. then the command line's options (``--image-size`` ...), which override either, with a note.

With motor noise (``endpoint_noise`` > 0) a row's trial is replayed with the row's ``seed`` -- the
very landing error that made it, which only a simulation knows -- or, with ``motor_draws`` K >= 2
(``--motor-draws``), observed K times with K landing errors of its own (seeds from the design cell:
``draw_seed``): the prediction is then the mean of the K read-outs and the likelihood adds their
variance to the report noise's (``likelihood.Evaluator``), the motor noise marginalised as real data
need (a person's landing errors are unknown).

Per row, the data may also carry ``seed`` (used when endpoint noise makes trials differ by seed),
``flash_dx_deg``/``flash_dy_deg`` (the flash's offset from the target as designed; otherwise it is
``true - target``) and ``paradigm``; data of the ``separation`` or ``displacement`` paradigm are
refused (the fit models localization reports).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..psychophysics import TrialConfig

__all__ = [
    "ForwardModel",
    "forward_model",
    "config_from_fingerprint",
    "draw_seed",
    "ForwardModelError",
    "OBSERVING_OPTIONS",
    "MAX_MOTOR_DRAWS",
]

#: Options of ``fit``/``compare`` that set the observing configuration (``TrialConfig`` fields).
OBSERVING_OPTIONS = ("image_size", "fovy_deg", "fovea_deg", "saccade_model", "endpoint_noise", "generator")
_ROW_COLUMNS = ("seed", "flash_dx_deg", "flash_dy_deg", "paradigm", "config_hash")
#: The most landing errors a trial is observed with (``motor_draws``): each is a rendered trial.
MAX_MOTOR_DRAWS = 64


def draw_seed(amplitude_deg: float, flash_time_ms: int, dx_deg: float, dy_deg: float, k: int) -> int:
    """The trial seed of landing error ``k`` of a design cell (``motor_draws``): a CRC-32 of the cell and
    ``k`` -- the same cell gets the same K draws in every data set (the observations cache is shared),
    and different cells independent ones."""
    import zlib

    text = f"{float(amplitude_deg)!r},{int(flash_time_ms)},{round(float(dx_deg), 6)!r},{round(float(dy_deg), 6)!r},{k}"
    return zlib.crc32(text.encode()) & 0x7FFFFFFF


class ForwardModelError(ValueError):
    """The data's design cannot be reproduced by the fit (another paradigm, a sidecar that does
    not belong to the table, a configuration out of bounds)."""


@dataclasses.dataclass(frozen=True)
class ForwardModel:
    """What the fit re-runs: ``config`` (a ``TrialConfig``; its condition is set per row) and per
    row its designed flash offset ``offset_deg`` (R, 2) and trial ``seed`` (R,); ``motor_draws``: 0,
    each row's trial replayed with its seed, or K >= 2 landing errors per trial, marginalised (the
    module docstring)."""

    config: TrialConfig
    offset_deg: np.ndarray
    seed: np.ndarray
    source: str
    motor_draws: int = 0

    def fingerprint(self) -> dict:
        from ..psychophysics import Design, config_fingerprint

        cfg = config_fingerprint(
            Design(amplitudes_deg=(1.0,), flash_offsets_deg=((0.0, 0.0),), flash_times_ms=(0,)), self.config
        )["config"]
        out = {k: v for k, v in cfg.items() if k != "condition"}
        if self.motor_draws:  # (absent at 0: the fits and their keys from before the option stay valid)
            out["motor_draws"] = int(self.motor_draws)
        return out


def config_from_fingerprint(cfg: dict):
    """The ``TrialConfig`` of a ``run.json``-style ``config`` dict (the time course flattened)."""
    from ..psychophysics import RemapTimeCourse, TrialConfig
    from ..psychophysics.observer import ObserverParams
    from ..psychophysics.population import PopulationParams

    fields = {f.name for f in dataclasses.fields(TrialConfig)}
    tc_names = ("peak_time_ms", "rise_ms", "decay_ms", "peak_gain")
    unknown = sorted(set(cfg) - fields - set(tc_names))
    if unknown:
        raise ForwardModelError(f"unknown configuration field(s) {', '.join(unknown)}")
    kw: dict[str, Any] = {k: (tuple(v) if k == "disabled" else v) for k, v in cfg.items() if k in fields}
    if "markers" in kw and isinstance(kw["markers"], list):
        kw["markers"] = tuple(tuple(m) if isinstance(m, list) else m for m in kw["markers"])
    import models

    for name, kind in (
        ("observer", ObserverParams),
        ("population", PopulationParams),
        ("generator", models.BurstGenerator),
    ):
        if isinstance(kw.get(name), dict):
            try:
                kw[name] = kind(**kw[name])
            except (TypeError, ValueError) as e:
                raise ForwardModelError(f"the configuration's {name} constants cannot be used: {e}") from None
    tc = {k: cfg[k] for k in tc_names if k in cfg}
    if tc:
        kw["timecourse"] = RemapTimeCourse(**{**dataclasses.asdict(RemapTimeCourse()), **tc})
    try:
        return TrialConfig(**kw)
    except (TypeError, ValueError) as e:
        raise ForwardModelError(f"the configuration cannot be used: {e}") from None


def _row_columns(path: Path, n_rows: int) -> dict[str, np.ndarray]:
    """The optional per-row columns (``_ROW_COLUMNS``) of the data file, as strings."""
    if path.suffix.lower() == ".parquet":
        import pyarrow.parquet as pq

        t = pq.read_table(path)
        cols = {
            c: np.asarray([("" if v is None else str(v)) for v in t.column(c).to_pylist()])
            for c in _ROW_COLUMNS
            if c in t.column_names
        }
    else:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.DictReader(fh)
            names = [(n or "").strip() for n in (reader.fieldnames or [])]
            want = [c for c in _ROW_COLUMNS if c in names]
            rows = [{(k or "").strip(): v for k, v in r.items()} for r in reader]
        cols = {c: np.asarray([(r.get(c) or "").strip() for r in rows]) for c in want}
    return {c: v for c, v in cols.items() if len(v) == n_rows}


def _sidecar(path: Path, cols: dict) -> tuple[dict | None, str]:
    meta_path = path.with_name("run.json") if path.stem == "trials" else path.with_suffix(".json")
    if not meta_path.is_file():
        return None, ""
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ForwardModelError(f"{meta_path}: unreadable sidecar ({e}); fix or remove it") from None
    if not isinstance(meta, dict) or not isinstance(meta.get("config"), dict):
        return None, ""  # not a configuration sidecar (e.g. an older simulate's metadata): defaults
    if "config_hash" in cols and "config_hash" in meta:
        foreign = sorted(set(cols["config_hash"]) - {str(meta["config_hash"])})
        if foreign:
            raise ForwardModelError(
                f"{meta_path} does not describe {path}: the table's rows carry config_hash "
                f"{', '.join(foreign[:3])}, the sidecar {meta['config_hash']}"
            )
    return meta["config"], str(meta_path)


def forward_model(
    data, overrides: dict | None = None, *, note: bool = True, motor_draws: int | None = None
) -> ForwardModel:
    """The forward model of ``data`` (a ``LocalizationData`` read from ``data.source``) with the
    command line's ``overrides`` (``OBSERVING_OPTIONS`` -> value; ``None`` = not given). ``note``: say
    on stderr which overrides change the data's sidecar (off where the caller sets them by design).
    ``motor_draws``: 0/None (replay the rows' seeds) or 2..``MAX_MOTOR_DRAWS`` landing errors per trial
    (needs ``endpoint_noise`` > 0)."""
    from ..psychophysics import TrialConfig

    draws = 0 if motor_draws is None else motor_draws
    if (
        isinstance(draws, bool)
        or not isinstance(draws, (int, np.integer))
        or not (draws == 0 or 2 <= draws <= MAX_MOTOR_DRAWS)
    ):
        raise ForwardModelError(
            f"motor_draws must be 0 (replay each row's seed) or a whole number from 2 to {MAX_MOTOR_DRAWS} "
            f"(landing errors per trial: one gives no variance); got {motor_draws!r}"
        )

    path = Path(data.source) if data.source else None
    cols = _row_columns(path, len(data)) if path is not None and path.is_file() else {}
    cfg_dict, source = _sidecar(path, cols) if path is not None and path.is_file() else (None, "")
    config = config_from_fingerprint(cfg_dict) if cfg_dict is not None else TrialConfig()
    if config.paradigm != "localization":
        raise ForwardModelError(
            f"{source}: the data come from the {config.paradigm} paradigm; the fit models "
            "localization reports (one flash per trial)"
        )
    if "paradigm" in cols:
        bad = np.flatnonzero(~np.isin(cols["paradigm"], ("localization", "")))
        if bad.size:
            raise ForwardModelError(
                f"{data.source}: rows {', '.join(str(i + 2) for i in bad[:5])} are from the "
                f"{cols['paradigm'][bad[0]]} paradigm (column paradigm); the fit models "
                "localization reports only: remove those rows"
            )
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    changed = {k: v for k, v in given.items() if getattr(config, k) != v}
    if changed and source and note:
        print(
            f"note: {', '.join(f'{k}={v}' for k, v in changed.items())} from the command line override {source}",
            file=sys.stderr,
        )
    try:
        config = dataclasses.replace(config, **given, condition="references")
    except (TypeError, ValueError) as e:
        raise ForwardModelError(f"the observing configuration cannot be used: {e}") from None
    a = data.amplitude_deg
    offset = np.column_stack([data.true_deg[:, 0] - a / 2, data.true_deg[:, 1]])
    if "flash_dx_deg" in cols and "flash_dy_deg" in cols:
        try:
            designed = np.column_stack([cols["flash_dx_deg"].astype(float), cols["flash_dy_deg"].astype(float)])
        except ValueError:
            raise ForwardModelError(
                f"{data.source}: columns flash_dx_deg/flash_dy_deg hold values that are not numbers"
            ) from None
        far = np.flatnonzero(~(np.abs(designed - offset) < 0.05).all(axis=1))
        if far.size:
            raise ForwardModelError(
                f"{data.source}: rows {', '.join(str(i + 2) for i in far[:5])}: flash_dx_deg/"
                "flash_dy_deg disagree with true_x_deg - saccade_amplitude_deg/2 and true_y_deg "
                "by more than 0.05 deg; fix the columns or remove flash_dx_deg/flash_dy_deg"
            )
        offset = designed
    if draws and not config.endpoint_noise > 0:
        raise ForwardModelError(
            f"--motor-draws {draws} marginalises the saccades' motor noise, but the forward model has none "
            f"(endpoint_noise {config.endpoint_noise:g}, from {source or 'the TrialConfig defaults'}): give "
            "--endpoint-noise (e.g. 0.05, Kowler & Blaser 1995) or leave --motor-draws out"
        )
    seed = np.zeros(len(data), np.int64)
    if "seed" in cols:
        try:
            s = cols["seed"].astype(float)
        except ValueError:
            raise ForwardModelError(f"{data.source}: column seed holds values that are not numbers") from None
        ok = np.isfinite(s) & (s == np.round(s)) & (s >= 0) & (s < 2**31)
        if not ok.all():
            raise ForwardModelError(
                f"{data.source}: column seed must hold whole numbers in [0, 2^31); rows "
                f"{', '.join(str(i + 2) for i in np.flatnonzero(~ok)[:5])}"
            )
        seed = s.astype(np.int64)
    elif config.endpoint_noise > 0 and not draws:
        print(
            f"note: endpoint noise {config.endpoint_noise:g} but {data.source} has no seed column: every trial "
            "is observed with seed 0 (one landing error); --motor-draws K marginalises over K of them",
            file=sys.stderr,
        )
    return ForwardModel(
        config=config, offset_deg=offset, seed=seed, source=source or "TrialConfig defaults", motor_draws=int(draws)
    )
