"""Cached observations of a fit, stored as data that cannot run code: ``.npz`` read with
``allow_pickle=False``, verified before use.

A results folder is data that people share and download; a pickle in it would run arbitrary
code when a fit resumes. Each ``OUT/observations/<condition>-<key>.npz`` holds plain numeric
arrays only, plus a ``meta`` entry (a JSON string stored as a numpy unicode array) with

* ``key``: the hash of the trials and of every field of the observing configuration
  (``observe.observation_key``), which the file name also carries;
* ``sha256``: a checksum over every array's name, dtype, shape and bytes;
* ``format``: this module's format version.

:func:`load` returns the observations only when the file reads without pickle, its key and
checksum match, and every trial and every saccade plan rebuilt from it agrees with what was
stored; otherwise it returns ``None`` with the reason, and the caller observes again (and says so).
A saccade plan is stored as its numbers; its generator and vergence dynamics are the observing
head's own (deterministic functions of the configuration), and the rebuilt plan must reproduce the
stored eye trajectory to 1e-9 rad, so a cache made by another version of the oculomotor model is
rebuilt rather than used.

What a fit needs of a trial (``TrialRunner.readout``) is kept; the rendered frames and the retina's
own view (used only by recordings) are not.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["FORMAT", "save", "load"]

FORMAT = 3  # 3: the references' landmarks (``ref_landmark_z``, ``ref_landmark_cov``)
_PLAN_FIELDS = ("start_angles", "end_angles", "intended_end_angles", "signal_start_angles")
_PLAN_OPTIONAL = ("target", "intended_target")
_CHECK_POINTS = 16  # times at which a rebuilt plan must reproduce the stored trajectory
#: Landmarks stored per eye (NaN-padded); a trial whose references show more cannot be cached.
MAX_LANDMARKS = 16


def _checksum(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _check_times(plan) -> np.ndarray:
    return np.linspace(plan.onset_ms - 5.0, plan.end_ms + 50.0, _CHECK_POINTS)


def _pack(observations: list) -> dict[str, np.ndarray]:
    """The observations as named arrays (one leading axis over trials)."""
    o0 = observations[0]
    n_flash = len(o0.flashes)
    a: dict[str, list] = {
        k: []
        for k in (
            "trial",
            "onset_ms",
            "scalars",
            "eye_position",
            *_PLAN_FIELDS,
            *_PLAN_OPTIONAL,
            "has_target",
            "plan_check",
            "copy_axes",
            "copy_origins",
            "target_deg",
            "eye_h",
            "seen_z",
            "ref_z",
            "ref_activity",
            "ref_on_ms",
            "ref_landmark_z",
            "ref_landmark_cov",
        )
    }
    per_flash: dict[str, list] = {
        f"flash{f}_{k}": []
        for f in range(n_flash)
        for k in ("head", "true_deg", "z_t", "periphery", "fovea", "mask", "fovea_mask")
    }
    a.update(per_flash)
    for o in observations:
        t, p = o.trial, o.plan
        if len(o.flashes) != n_flash:
            raise ValueError("observations with different numbers of flashes cannot share a cache file")
        a["trial"].append(
            [t.trial_id, t.amplitude_deg, t.flash_dx_deg, t.flash_dy_deg, t.flash_time_ms, t.repetition, t.seed]
        )
        a["onset_ms"].append(p.onset_ms)
        a["scalars"].append([p.amplitude, p.intended_amplitude, o.t_abs, o.t_mid, o.exposure, o.t_post])
        a["eye_position"].append([p.eye_position.sigma_ms, p.eye_position.delay_ms])
        for k in _PLAN_FIELDS:
            a[k].append(getattr(p, k))
        a["has_target"].append([getattr(p, k) is not None for k in _PLAN_OPTIONAL])
        for k in _PLAN_OPTIONAL:
            v = getattr(p, k)
            a[k].append(np.full(3, np.nan) if v is None else np.asarray(v, float))
        a["plan_check"].append(np.stack([p.angles(float(s)) for s in _check_times(p)]))
        a["copy_axes"].append(o.copy_pose[0])
        a["copy_origins"].append(o.copy_pose[1])
        a["target_deg"].append(o.target_deg)
        a["eye_h"].append(o.eye_h)
        a["seen_z"].append(np.array(o.seen_z, complex))
        a["ref_z"].append(np.array(o.ref_z if o.ref_z is not None else [np.nan] * 2, complex))
        a["ref_activity"].append(np.asarray(o.ref_activity if o.ref_activity is not None else [0.0, 0.0], float))
        a["ref_on_ms"].append(float(o.ref_on_ms))
        lz, lc = np.full((2, MAX_LANDMARKS), np.nan, complex), np.full((2, MAX_LANDMARKS, 2, 2), np.nan)
        for e, (z, c) in enumerate(o.ref_landmarks or ()):
            if len(z) > MAX_LANDMARKS:
                raise ValueError(
                    f"trial {t.trial_id}: the references show {len(z)} landmarks to one eye; at most "
                    f"{MAX_LANDMARKS} can be cached"
                )
            lz[e, : len(z)], lc[e, : len(z)] = z, c
        a["ref_landmark_z"].append(lz)
        a["ref_landmark_cov"].append(lc)
        for f, fl in enumerate(o.flashes):
            a[f"flash{f}_head"].append(fl["head"])
            a[f"flash{f}_true_deg"].append(fl["true_deg"])
            a[f"flash{f}_z_t"].append([e[2] for e in fl["eyes"]])
            for k in ("periphery", "fovea", "mask", "fovea_mask"):
                a[f"flash{f}_{k}"].append(np.stack([getattr(e[1], k) for e in fl["eyes"]]))
    out = {k: np.asarray(v) for k, v in a.items()}
    out["trial"] = out["trial"].astype(float)
    out["onset_ms"] = out["onset_ms"].astype(np.int64)
    for f in range(n_flash):
        out[f"flash{f}_z_t"] = out[f"flash{f}_z_t"].astype(complex)
    for k, v in out.items():
        if v.dtype == object:
            raise TypeError(f"observation field {k} is not numeric; it cannot be cached without pickle")
    return out


def save(path: Path, observations: list, key: str) -> None:
    """Write ``observations`` to ``path`` (atomically; numeric arrays and a JSON ``meta`` only)."""
    from ..folders import atomic_write_bytes

    if not observations:
        raise ValueError("no observations to cache")
    arrays = _pack(observations)
    meta = {
        "format": FORMAT,
        "key": key,
        "n": len(observations),
        "n_flashes": len(observations[0].flashes),
        "sha256": _checksum(arrays),
    }
    buf = io.BytesIO()
    # Any: numpy's stubs match the ** entries against savez's allow_pickle: bool as well
    entries: dict[str, Any] = arrays
    np.savez(buf, meta=np.array(json.dumps(meta)), **entries)
    atomic_write_bytes(path, buf.getvalue())


def load(path: Path, key: str, trials: list, runner) -> tuple[list | None, str]:
    """``(observations, "")`` from ``path`` if it is a valid cache of ``trials`` under ``key``,
    rebuilt against ``runner`` (the observing ``TrialRunner``: its head's generator, its map's
    grid); else ``(None, reason)``."""
    if not path.exists():
        return None, "not cached yet"
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as e:
        return None, f"unreadable ({type(e).__name__}: {str(e)[:80]})"
    try:
        meta = json.loads(str(arrays.pop("meta")[()]))
    except (KeyError, ValueError, TypeError):
        return None, "no valid meta entry"
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        return None, f"format {meta.get('format') if isinstance(meta, dict) else '?'} is not {FORMAT}"
    if meta.get("key") != key:
        return None, "made for other trials or another configuration"
    if meta.get("sha256") != _checksum(arrays):
        return None, "checksum mismatch (the file was changed or damaged)"
    if meta.get("n") != len(trials):
        return None, "holds another number of trials"
    try:
        return _unpack(arrays, int(meta["n_flashes"]), trials, runner), ""
    except (KeyError, ValueError, TypeError, IndexError) as e:
        return None, f"inconsistent ({type(e).__name__}: {str(e)[:80]})"


def _unpack(a: dict, n_flash: int, trials: list, runner) -> list:
    import dataclasses

    import models

    from ..psychophysics.targetmap import CentredSamples
    from ..psychophysics.trial import Observation

    head, grid = runner.head, runner.map.grid
    generator = head.main_sequence if runner.config.saccade_model == "legacy" else head.generator
    out = []
    for i, t in enumerate(trials):
        stored = a["trial"][i]
        mine = np.array(
            [t.trial_id, t.amplitude_deg, t.flash_dx_deg, t.flash_dy_deg, t.flash_time_ms, t.repetition, t.seed], float
        )
        if not np.array_equal(stored, mine):
            raise ValueError(f"trial {i} differs from the one asked for")
        amp, iamp, t_abs, t_mid, exposure, t_post = (float(v) for v in a["scalars"][i])
        kw = {k: a[k][i] for k in _PLAN_FIELDS}
        for j, k in enumerate(_PLAN_OPTIONAL):
            kw[k] = a[k][i] if a["has_target"][i][j] else None
        plan = models.SaccadePlan(
            onset_ms=int(a["onset_ms"][i]),
            amplitude=amp,
            intended_amplitude=iamp,
            generator=generator,
            vergence=head.vergence,
            eye_position=models.EyePositionSignal(*(float(v) for v in a["eye_position"][i])),
            **kw,
        )
        got = np.stack([plan.angles(float(s)) for s in _check_times(plan)])
        if got.shape != a["plan_check"][i].shape or not np.allclose(got, a["plan_check"][i], rtol=0, atol=1e-9):
            raise ValueError(
                f"trial {i}: the saccade plan rebuilt from the cache does not reproduce the stored "
                "trajectory (another version of the oculomotor model)"
            )
        flashes = []
        for f in range(n_flash):
            eyes = []
            for e in range(2):
                cs = CentredSamples(
                    grid, *(a[f"flash{f}_{k}"][i][e] for k in ("periphery", "fovea", "mask", "fovea_mask"))
                )
                eyes.append((None, cs, complex(a[f"flash{f}_z_t"][i][e])))
            flashes.append({"eyes": eyes, "head": a[f"flash{f}_head"][i], "true_deg": a[f"flash{f}_true_deg"][i]})
        out.append(
            Observation(
                trial=dataclasses.replace(t),
                plan=plan,
                t_abs=int(t_abs),
                t_mid=t_mid,
                exposure=exposure,
                copy_pose=(a["copy_axes"][i], a["copy_origins"][i]),
                flashes=flashes,
                target_deg=a["target_deg"][i],
                eye_h=a["eye_h"][i],
                seen_z=[complex(z) for z in a["seen_z"][i]],
                t_post=int(t_post),
                ref_z=[complex(z) for z in a["ref_z"][i]],
                ref_activity=np.array(a["ref_activity"][i]),
                ref_on_ms=float(a["ref_on_ms"][i]),
                ref_landmarks=[
                    (a["ref_landmark_z"][i][e][keep], a["ref_landmark_cov"][i][e][keep])
                    for e in range(2)
                    for keep in [np.isfinite(a["ref_landmark_z"][i][e].real)]
                ],
            )
        )
    return out
