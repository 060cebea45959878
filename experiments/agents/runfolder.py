"""A training run's folder, kept to ``run``'s promises: one run's settings per folder, resumable.

``train.json`` holds the settings of the run (algorithm, task, seed, hyper-parameters, budget) and
is written, atomically, before any other file. A folder whose ``train.json`` differs is another
run's and is refused, naming what differs; a folder with result files but no ``train.json`` (an
older layout, or not a training run at all) is refused too. ``checkpoint.npz`` (one file: weights,
optimizer and random-number state, for SAC the replay buffer, and the metadata; see
:mod:`experiments.agents.saved`) is replaced atomically after every evaluation; the finished
model is written last. So a kill -9 at any moment leaves the previous finished run untouched (the
new one was refused) or a new run that the same command resumes.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..folders import write_json

__all__ = ["CHECKPOINT", "SETTINGS", "check_settings"]

SETTINGS = "train.json"
CHECKPOINT = "checkpoint.npz"


def check_settings(out: Path, settings: dict[str, Any]) -> None:
    """Refuse ``out`` when it holds another run (``ValueError`` naming what differs); write
    ``train.json`` when the folder starts a new run."""
    path = out / SETTINGS
    new = json.loads(json.dumps(settings))  # as it reads back (tuples as lists)
    if path.exists():
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as err:
            raise ValueError(
                f"{path} cannot be read ({type(err).__name__}); this folder's run is unknown: use another --out"
            ) from None
        if not isinstance(old, dict):
            raise ValueError(f"{path} does not hold a JSON object; use another --out")
        if old != new:
            diff = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
            raise ValueError(
                f"{out} holds another training run (differs in: {', '.join(diff)}); use another --out, "
                "or the same options to resume or report it"
            )
        return
    other = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    if other:
        raise ValueError(
            f"{out} holds files but no {SETTINGS} ({', '.join(other[:4])}"
            f"{', ...' if len(other) > 4 else ''}): not a run of this version of train; "
            "use another (empty) --out"
        )
    write_json(path, new)
