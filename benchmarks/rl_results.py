"""The one RL results table: ``experiments/data/rl_results.csv``, filled from ``baselines`` folders.

Every RL number the docs cite is a row of that CSV (docs/rl.md's table is its rendering by
``benchmarks/tables.py``). A row comes from the ``table.csv`` that ``python -m experiments baselines``
writes (IQM over seeds with a percentile-bootstrap 95 % CI, Agarwal et al. 2021), with the engine, device
and code it was measured with::

    python -m experiments baselines --task fixate --agents ppo cem sac --seeds 0 1 2 --out runs/rl_fixate
    python benchmarks/rl_results.py runs/rl_fixate --engine single --device cpu
    python benchmarks/tables.py docs/rl.md

A folder's rows replace the CSV's rows of the same agent, task, engine, device and action mode; other rows
are kept. The CSV is replaced atomically.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_CSV = ROOT / "experiments" / "data" / "rl_results.csv"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from tables import RL_COLUMNS  # noqa: E402  (the renderer's column list is the writer's: one home)

__all__ = ["rows_from_baselines", "rows_from_train", "wilson_interval", "merge", "main"]

_KEY = ("agent", "task", "engine", "device", "actions")
_TABLE = ("agent", "actions", "seeds", "iqm", "ci_low", "ci_high", "per_seed", "mean_return", "env_steps", "wall_s")


def _code() -> str:
    """The commit measured: ``git rev-parse --short HEAD`` of this repository (a ``+`` where the tree has edits)."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        raise ValueError("cannot read the commit measured (not a git checkout): give --code") from None
    return head + ("+" if dirty else "")


def rows_from_baselines(folder: str | os.PathLike, engine: str, device: str, code: str, note: str = "") -> list[dict]:
    """The RL results rows of one ``baselines`` folder (its ``study.json`` and ``table.csv``). Raises
    ValueError naming the file where the folder is not a finished ``baselines`` run."""
    folder = Path(folder)
    try:
        study = json.loads((folder / "study.json").read_text())
        with open(folder / "table.csv", newline="") as f:
            reader = csv.DictReader(f)
            table, fields = list(reader), reader.fieldnames or []
    except (OSError, json.JSONDecodeError) as e:
        raise ValueError(
            f"{folder} is not a finished `python -m experiments baselines` folder (study.json and table.csv): {e}"
        ) from None
    missing = [c for c in _TABLE if c not in fields]
    if missing or not table or "task" not in study:
        raise ValueError(
            f"{folder}/table.csv is not a baselines table: "
            f"{'no column ' + ', '.join(missing) if missing else 'no rows or no task'}"
        )
    for name, value in (("engine", engine), ("device", device), ("code", code)):
        if not value.strip() or "," in value or "\n" in value:
            raise ValueError(f"--{name} must be a non-empty word without commas, got {value!r}")
    return [
        {
            "agent": r["agent"],
            "task": study["task"],
            "engine": engine,
            "device": device,
            "actions": r["actions"],
            "env_steps": r["env_steps"],
            "wall_s": r["wall_s"],
            "seeds": "" if r["seeds"] == "-" else r["seeds"],
            "heldout_success_iqm": r["iqm"],
            "ci_low": r["ci_low"],
            "ci_high": r["ci_high"],
            "per_seed": r["per_seed"],
            "mean_return": r["mean_return"],
            "code": code,
            "note": note,
        }
        for r in table
    ]


def wilson_interval(successes: int, n: int) -> tuple[float, float]:
    """The Wilson score 95 % interval of a binomial proportion (Wilson 1927, JASA 22:209), by scipy."""
    from scipy.stats import binomtest

    if n <= 0 or not 0 <= successes <= n:
        raise ValueError(f"need 0 <= successes <= n and n > 0, got {successes} of {n}")
    ci = binomtest(successes, n).proportion_ci(confidence_level=0.95, method="wilson")
    return float(ci.low), float(ci.high)


def rows_from_train(folder: str | os.PathLike, code: str, note: str = "") -> list[dict]:
    """The RL results row of one finished ``python -m experiments train --engine batched`` folder (its
    ``ppo.json``): one seed, so the interval is the Wilson 95 % interval over its held-out episodes (said
    in the note), not a bootstrap over seeds. Raises ValueError naming the file where it is not one."""
    folder = Path(folder)
    try:
        meta = json.loads((folder / "ppo.json").read_text())
        held = meta["heldout_batched"]
        k = round(float(held["success_rate"]) * int(held["episodes"]))
        row = {
            "agent": "PPO batched (cortical conv, cell action)",
            "task": meta["task"],
            "engine": meta["engine"],
            "device": meta.get("device_name") or meta["device"],
            "actions": "deterministic" if held.get("deterministic", True) else "stochastic",
            "env_steps": str(int(meta["env_steps"])),
            "wall_s": f"{float(meta['wall_s']):.0f}",
            "seeds": str(int(meta["seed"])),
            "heldout_success_iqm": f"{float(held['success_rate']):.4g}",
            "per_seed": f"{float(held['success_rate']):.2f}",
            "mean_return": f"{float(held['mean_reward']):.4g}",
        }
        lo, hi = wilson_interval(k, int(held["episodes"]))
    except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as e:
        raise ValueError(
            f"{folder}/ppo.json is not a finished `python -m experiments train --engine batched` run: {e!r}"
        ) from None
    if meta["engine"] != "batched":
        raise ValueError(f"{folder}/ppo.json is a {meta['engine']!r} run; rl_results reads batched train folders")
    one_seed = f"one seed: 95 % Wilson interval over its {int(held['episodes'])} held-out episodes"
    return [
        {
            **row,
            "ci_low": f"{lo:.2f}",
            "ci_high": f"{hi:.2f}",
            "code": code,
            "note": f"{one_seed}; {note}" if note else one_seed,
        }
    ]


def merge(csv_path: str | os.PathLike, rows: list[dict]) -> list[dict]:
    """Replace ``csv_path``'s rows of the same agent, task, engine, device and actions by ``rows`` (appending
    new ones), write it atomically, and return the table."""
    csv_path = Path(csv_path)
    old: list[dict] = []
    if csv_path.exists():
        with open(csv_path, newline="") as f:
            reader = csv.DictReader(f)
            if list(reader.fieldnames or []) != list(RL_COLUMNS):
                raise ValueError(f"{csv_path} does not have the RL results columns {', '.join(RL_COLUMNS)}")
            old = list(reader)
    new = {tuple(r[k] for k in _KEY): r for r in rows}
    table = [new.pop(tuple(r[k] for k in _KEY), r) for r in old] + list(new.values())
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=RL_COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows(table)
    fd, tmp = tempfile.mkstemp(dir=csv_path.parent, prefix=csv_path.name + ".")
    with os.fdopen(fd, "w") as f:
        f.write(buf.getvalue())
    os.replace(tmp, csv_path)
    return table


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "folders",
        nargs="+",
        help="finished `python -m experiments baselines` folders, or `train --engine batched` folders (ppo.json)",
    )
    ap.add_argument("--engine", default="single", help="the env engine trained on: single or batched (default single)")
    ap.add_argument("--device", default="cpu", help="the device trained on, e.g. cpu or an H100 (default cpu)")
    ap.add_argument("--code", help="the commit measured (default: this checkout's, with + where it has edits)")
    ap.add_argument("--note", default="", help="a note kept with the rows (the machine, its load)")
    ap.add_argument(
        "--csv", default=str(DEFAULT_CSV), help="the results table (default experiments/data/rl_results.csv)"
    )
    args = ap.parse_args(argv)
    try:
        code = args.code or _code()
        rows = [
            r
            for d in args.folders
            for r in (
                rows_from_train(d, code, args.note)
                if (Path(d) / "ppo.json").exists() and not (Path(d) / "study.json").exists()
                else rows_from_baselines(d, args.engine, args.device, code, args.note)
            )
        ]
        table = merge(args.csv, rows)
    except ValueError as e:
        ap.error(str(e))
    print(f"{len(rows)} rows from {len(args.folders)} folder(s) written to {args.csv} ({len(table)} rows in all)")


if __name__ == "__main__":
    main()
