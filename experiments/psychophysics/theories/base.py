"""What every perception theory provides: its read-out of an observed trial, and its share of the
displacement paradigm. A theory is one object registered by name (``theories.REGISTRY``); the trial
runner asks the registry for ``TrialConfig.model`` and never branches on a theory's name."""

from __future__ import annotations

import dataclasses

from ..mechanisms import MECHANISMS

__all__ = ["Theory", "ConstantsTheory"]


class Theory:
    """A perception theory. ``name``: its ``TrialConfig.model``; ``switchable``: the ingredients
    (``mechanisms.MECHANISMS``) that ``TrialConfig.disabled`` switches off for it (none by default:
    a theory without switches reads ``disabled`` as empty)."""

    name: str = ""
    switchable: tuple[str, ...] = ()
    #: whether the theory's compression follows ``TrialConfig.timecourse`` (reports then show it)
    uses_timecourse: bool = False

    def describe(self, cfg) -> list[str]:
        """Lines for a study's text report saying how ``cfg`` sets the theory up (none by default)."""
        return []

    def mechanisms_on(self, cfg) -> dict[str, bool]:
        """Each ``mechanisms.MECHANISMS`` ingredient: on unless switchable and disabled."""
        return {m: not (m in self.switchable and m in cfg.disabled) for m in MECHANISMS}

    def read(self, runner, obs, plan, true_pose, cfg) -> tuple[list, float, float]:
        """The perceived positions of every flash of an observed trial: ``(reads, gain, weight)``
        with ``reads`` one ``(perceived per eye, closed form per eye, maps)`` per flash, ``gain``
        the theory's compression drive (the table's ``gain`` column) and ``weight`` its reference
        weight (the ``reference_weight`` column)."""
        raise NotImplementedError

    def displacement_looks(self, runner, plan, looks, cfg):
        """The target's head-centred positions before and after the saccade, and the s.d. of the
        report's noise, as ``(pre, post, sd)``, from ``looks`` = ((t_pre, zs_pre), (t_post, zs_post))
        (each eye's retinal image points of the target); None: the runner's (through the
        eye-position signal, ``TrialConfig.report_noise_deg``)."""
        return None

    def stability_weight(self, cfg, mismatch_deg: float, amplitude_deg: float, on: dict) -> float:
        """The weight of the assumption that the target did not move (0: none), given the target's
        retinal offset from the fovea at landing."""
        return 0.0


class ConstantsTheory(Theory):
    """A theory whose constants are one dataclass, ``TrialConfig.<name>``: its report line lists them."""

    def describe(self, cfg) -> list[str]:
        """The theory's constants, as set in ``cfg``."""
        params = getattr(cfg, self.name)
        return [f"{self.name} constants: " + ", ".join(f"{k} {v:g}" for k, v in dataclasses.asdict(params).items())]
