"""What marks a folder written by ``train --engine batched`` (importable without torch)."""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["FORMAT", "is_batched_folder"]

#: The ``format`` of a batched-PPO folder's ``ppo.json``.
FORMAT = "batched-ppo-npz-1"


def is_batched_folder(directory: str | Path) -> bool:
    """Whether ``directory/ppo.json`` names :data:`FORMAT` (a run of ``train --engine batched``)."""
    try:
        meta = json.loads((Path(directory) / "ppo.json").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return isinstance(meta, dict) and meta.get("format") == FORMAT
