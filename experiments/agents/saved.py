"""Agents on disk as data, never code: arrays in one ``.npz`` (read with ``allow_pickle=False``) whose
JSON metadata travels inside the same file, written atomically as one unit.

A results folder may come from anywhere; pickle (and so ``torch.load`` and Stable-Baselines3's zip)
runs code while it loads, so nothing here reads either. :func:`write_unit` stores arrays plus one
JSON object (``__meta__``, UTF-8 bytes as a ``uint8`` array) in a single ``.npz`` through
:func:`experiments.folders.atomic_write_bytes`: a reader sees the previous file or the new one,
never weights beside metadata that does not describe them. :func:`read_unit` reads it back or
raises one clear :class:`ValueError`.

:func:`pack` / :func:`unpack` turn nested state (a torch ``state_dict``, an optimizer's state, RNG
states) into JSON plus named arrays and back; :func:`space_to_json` / :func:`space_from_json` do the
same for Gymnasium spaces (``Box``, ``Discrete``, ``Dict``); :func:`rng_state` /
:func:`set_rng_state` capture Python's, numpy's global and torch's generators.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import random
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from ..folders import atomic_write_bytes

__all__ = [
    "check_weights_sha256",
    "META_KEY",
    "file_sha256",
    "pack",
    "read_unit",
    "rng_state",
    "set_rng_state",
    "space_from_json",
    "space_to_json",
    "unpack",
    "write_unit",
]

META_KEY = "__meta__"


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def check_weights_sha256(weights: str | Path, expected: object, described_by: str) -> None:
    """``ValueError`` unless ``weights``' SHA-256 is ``expected``, the one recorded in the JSON file
    ``described_by``: a folder that mixes two runs, or was altered, is refused."""
    if expected != file_sha256(weights):
        raise ValueError(
            f"{weights} is not the file {described_by} describes (its SHA-256 differs): the folder mixes two "
            "runs or was altered; retrain"
        )


def write_unit(path: str | Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> Path:
    """``arrays`` and the JSON object ``meta`` as one ``.npz``, written atomically; returns the path."""
    if META_KEY in arrays:
        raise ValueError(f"{META_KEY!r} is reserved for the metadata")
    text = json.dumps(meta, allow_nan=False, sort_keys=True)
    buf = io.BytesIO()
    plain = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
    bad = [k for k, v in plain.items() if v.dtype == object]
    if bad:
        raise ValueError(f"arrays {bad[:3]} hold Python objects; only numeric arrays are saved")
    # Any: numpy's stubs match the ** entries against savez's allow_pickle: bool as well
    entries: dict[str, Any] = {**plain, META_KEY: np.frombuffer(text.encode("utf-8"), np.uint8)}
    np.savez(buf, **entries)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def read_unit(path: str | Path, hint: str = "retrain") -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The arrays and metadata of a file written by :func:`write_unit`; ``ValueError`` (ending in
    ``hint``) for a missing, torn or foreign file, a pickle included (never unpickled)."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"missing {p}")
    try:
        with np.load(p, allow_pickle=False) as z:
            if not isinstance(z, np.lib.npyio.NpzFile):
                raise ValueError("not an .npz archive")
            arrays = {k: np.array(z[k]) for k in z.files}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, RuntimeError) as err:
        raise ValueError(
            f"{p} could not be read as saved arrays ({type(err).__name__}: {_short(err)}); {hint}"
        ) from None
    raw = arrays.pop(META_KEY, None)
    if raw is None or raw.dtype != np.uint8 or raw.ndim != 1:
        raise ValueError(f"{p} holds no metadata: not written by this package; {hint}")
    try:
        meta = json.loads(raw.tobytes().decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as err:
        raise ValueError(f"{p}: its metadata is not valid JSON ({_short(err)}); {hint}") from None
    if not isinstance(meta, dict):
        raise ValueError(f"{p}: its metadata is not a JSON object; {hint}")
    return arrays, meta


def _short(err: BaseException) -> str:
    return str(err).splitlines()[0][:200] if str(err) else type(err).__name__


# ------------------------------------------------------------------------------------ nested state
def pack(tree: Any, prefix: str, arrays: dict[str, np.ndarray]) -> Any:
    """``tree`` (dicts, lists, tuples, numbers, strings, numpy arrays, torch tensors) as JSON: each
    array goes into ``arrays`` under a key starting with ``prefix`` and is replaced by
    ``{"@array": key}``; dicts become ``{"@dict": [[key, value], ...]}`` (keys may be ints)."""
    if isinstance(tree, dict):
        return {"@dict": [[k, pack(v, f"{prefix}/{k}", arrays)] for k, v in tree.items()]}
    if isinstance(tree, (list, tuple)):
        return {"@list": [pack(v, f"{prefix}/{i}", arrays) for i, v in enumerate(tree)]}
    if hasattr(tree, "detach") and hasattr(tree, "cpu"):  # a torch tensor
        tree = tree.detach().cpu().numpy()
    if isinstance(tree, np.ndarray):
        arrays[prefix] = tree.copy()
        return {"@array": prefix}
    if isinstance(tree, np.generic):
        tree = tree.item()
    if isinstance(tree, float) and not math.isfinite(tree):
        return {"@float": repr(tree)}
    if tree is None or isinstance(tree, (bool, int, float, str)):
        return tree
    raise TypeError(f"cannot save a {type(tree).__name__} at {prefix}")


def unpack(skeleton: Any, arrays: dict[str, np.ndarray], tensors: bool = False) -> Any:
    """The inverse of :func:`pack` (arrays as torch tensors when ``tensors``); ``ValueError`` for a
    skeleton that names a missing array or has an unknown shape."""
    if isinstance(skeleton, dict):
        if "@array" in skeleton:
            key = skeleton["@array"]
            if key not in arrays:
                raise ValueError(f"the saved state names a missing array {key!r}")
            a = arrays[key]
            if tensors:
                import torch

                return torch.from_numpy(np.array(a))
            return a
        if "@dict" in skeleton:
            return {k: unpack(v, arrays, tensors) for k, v in skeleton["@dict"]}
        if "@list" in skeleton:
            return [unpack(v, arrays, tensors) for v in skeleton["@list"]]
        if "@float" in skeleton:
            return float(skeleton["@float"])
        raise ValueError(f"unknown saved entry with keys {sorted(skeleton)[:4]}")
    if isinstance(skeleton, list):
        raise ValueError("a bare list in the saved state")
    return skeleton


# ------------------------------------------------------------------------------------------ spaces
def _bound(a: np.ndarray) -> Any:
    flat = np.unique(a)
    one = flat[0] if flat.size == 1 else None

    def enc(x):
        return x if math.isfinite(x) else repr(x)

    return enc(float(one)) if one is not None else [enc(float(x)) for x in a.ravel()]


def space_to_json(space) -> dict[str, Any]:
    """A Gymnasium ``Box``, ``Discrete`` or ``Dict`` space as JSON."""
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return {"type": "Dict", "spaces": {k: space_to_json(v) for k, v in space.spaces.items()}}
    if isinstance(space, spaces.Discrete):
        return {"type": "Discrete", "n": int(space.n), "start": int(space.start)}
    if isinstance(space, spaces.Box):
        return {
            "type": "Box",
            "shape": list(space.shape),
            "dtype": str(space.dtype),
            "low": _bound(space.low),
            "high": _bound(space.high),
        }
    raise ValueError(f"cannot save a {type(space).__name__} space")


def space_from_json(d: dict[str, Any]):
    """The inverse of :func:`space_to_json`; ``ValueError`` for anything else."""
    from gymnasium import spaces

    try:
        kind = d["type"]
        if kind == "Dict":
            return spaces.Dict({k: space_from_json(v) for k, v in d["spaces"].items()})
        if kind == "Discrete":
            return spaces.Discrete(int(d["n"]), start=int(d.get("start", 0)))
        if kind == "Box":
            shape = tuple(int(s) for s in d["shape"])
            dtype = np.dtype(d["dtype"])
            if dtype.kind not in "fiu":
                raise ValueError(f"dtype {dtype}")

            def arr(v):
                a = np.array([float(x) for x in v] if isinstance(v, list) else float(v), dtype=np.float64)
                return np.broadcast_to(a.reshape(shape) if a.ndim else a, shape).astype(dtype)

            return spaces.Box(arr(d["low"]), arr(d["high"]), shape, dtype)
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise ValueError(f"not a saved space ({type(err).__name__}: {err})") from None
    raise ValueError(f"unknown space type {kind!r}")


# --------------------------------------------------------------------------------------------- RNG
def rng_state(arrays: dict[str, np.ndarray], prefix: str = "rng") -> dict[str, Any]:
    """Python's, numpy's global and torch's (CPU) generator states: JSON, arrays into ``arrays``."""
    import torch

    name, keys, pos, has_gauss, gauss = np.random.get_state()
    arrays[f"{prefix}/numpy"] = np.asarray(keys)
    arrays[f"{prefix}/torch"] = torch.get_rng_state().numpy().copy()
    version, internal, gauss_next = random.getstate()
    return {"numpy": [name, int(pos), int(has_gauss), float(gauss)], "python": [version, list(internal), gauss_next]}


def set_rng_state(state: dict[str, Any], arrays: dict[str, np.ndarray], prefix: str = "rng") -> None:
    """Restore what :func:`rng_state` captured."""
    import torch

    try:
        name, pos, has_gauss, gauss = state["numpy"]
        np.random.set_state((name, arrays[f"{prefix}/numpy"].astype(np.uint32), pos, has_gauss, gauss))
        torch.set_rng_state(torch.from_numpy(arrays[f"{prefix}/torch"].astype(np.uint8)))
        version, internal, gauss_next = state["python"]
        random.setstate((version, tuple(internal), gauss_next))
    except (KeyError, TypeError, ValueError, RuntimeError) as err:
        raise ValueError(f"the saved random-number state is not valid ({type(err).__name__}: {err})") from None
