"""What a command is doing while it waits: one stage line on stderr, and progress bars whose rate and ETA
start after warm-up.

A command's first unit of work (a trial, a saccade, an episode) pays for numba's compilation (or
reading its on-disk cache), MuJoCo's model and scene build and the first render. Folding that into a
per-unit rate gives an ETA many times too long. So :class:`Progress` prints a stage line when it
opens (``flash trials: warming up (...)``) and starts its tqdm bar only when the first units are done:
the bar's clock, rate and ETA count from there. :func:`stage` prints one line for any other wait
(loading, fitting, writing figures). Everything goes to stderr and nothing is printed when the
command's ``--no-progress`` is given (``enabled=False``).
"""

from __future__ import annotations

import sys

#: what the first unit of most commands waits for (named in the warm-up line)
WARMUP = "warming up (loading MuJoCo and the scene, first render, compiling numba kernels on a first run)"


def stage(message: str, *, enabled: bool = True) -> None:
    """Print one line on stderr saying what the command does now (nothing when ``enabled`` is false)."""
    if enabled:
        print(message, file=sys.stderr, flush=True)


class Progress:
    """A tqdm bar on stderr whose clock starts when the first units are done, after a warm-up line.

    total : units in all; initial : units already done (a resumed run); desc, unit : tqdm's;
    warmup : the warm-up stage's text (printed as ``desc: warmup``), or ``None`` to start the bar at
    once (no warm-up to wait for); enabled : ``False`` prints nothing (``--no-progress``).
    tqdm's ``smoothing`` is lowered so that one slow batch does not swing the ETA.
    """

    def __init__(
        self,
        total: int,
        *,
        desc: str,
        unit: str,
        initial: int = 0,
        warmup: str | None = WARMUP,
        enabled: bool = True,
        smoothing: float = 0.1,
    ) -> None:
        self.total, self.desc, self.unit, self.smoothing = total, desc, unit, smoothing
        self.n = initial
        self.enabled = enabled
        self._bar = None
        if enabled and warmup is not None:
            stage(f"{desc}: {warmup}")
        elif enabled:
            self._open()

    def _open(self) -> None:
        from tqdm import tqdm

        self._bar = tqdm(
            total=self.total, initial=self.n, desc=self.desc, unit=self.unit, smoothing=self.smoothing, file=sys.stderr
        )

    def update(self, n: int = 1) -> None:
        """``n`` more units done; the first call after warm-up opens the bar (its clock starts here)."""
        self.n += n
        if not self.enabled:
            return
        if self._bar is None:
            self._open()
        else:
            self._bar.update(n)

    def close(self) -> None:
        """Close the bar (if it was opened)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
