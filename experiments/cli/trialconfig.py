"""Command-line options generated from ``TrialConfig``'s fields: the option ``--image-size`` for the
field ``image_size``, its default from ``psychophysics.trial_fields.TRIAL_DEFAULTS`` (the defaults
``TrialConfig`` takes), its range from ``psychophysics.bounds.LIMITS``, its choices from
``trial_fields.TRIAL_CHOICES``; the remapping time course's fields from ``RemapTimeCourse``.

``run`` declares its trial options through :func:`add_trial_options`, ``fit``, ``compare`` and
``simulate`` their forward model's. Nothing here imports MuJoCo or numba.
"""

from __future__ import annotations

import argparse
import dataclasses

from .parsing import bounded

__all__ = ["add_trial_options", "field_default", "option_name", "trial_field_names"]

#: The fields of ``RemapTimeCourse`` (``TrialConfig.timecourse``), options of their own.
TIMECOURSE = "timecourse"


def option_name(field: str) -> str:
    """The option of a field: ``image_size`` -> ``--image-size``."""
    return "--" + field.replace("_", "-")


def _timecourse_defaults() -> dict:
    from ..psychophysics.timecourse import RemapTimeCourse

    return {f.name: f.default for f in dataclasses.fields(RemapTimeCourse)}


def trial_field_names() -> tuple[str, ...]:
    """Every plain field of ``TrialConfig`` and of its ``RemapTimeCourse``."""
    from ..psychophysics.trial_fields import TRIAL_DEFAULTS

    return (*TRIAL_DEFAULTS, *_timecourse_defaults())


def field_default(field: str):
    """``TrialConfig``'s default of ``field`` (or its time course's)."""
    from ..psychophysics.trial_fields import TRIAL_DEFAULTS

    return TRIAL_DEFAULTS[field] if field in TRIAL_DEFAULTS else _timecourse_defaults()[field]


def add_trial_options(group, helps: dict[str, str], *, defaults: bool = True) -> None:
    """One option per field named in ``helps`` (field -> help text; ``{range}`` in it is replaced by
    the field's range, else the range is appended): a bounded number (``LIMITS``) or a choice
    (``TRIAL_CHOICES``). ``defaults``: ``TrialConfig``'s defaults; else None (the command fills
    them in, e.g. from a data set's sidecar)."""
    from ..psychophysics.bounds import LIMITS
    from ..psychophysics.trial_fields import TRIAL_CHOICES

    for field, text in helps.items():
        kw: dict = {"default": field_default(field) if defaults else None}
        if field in TRIAL_CHOICES:
            kw["choices"] = TRIAL_CHOICES[field]
        elif field in LIMITS:
            kw["type"] = bounded(field)
            rng = LIMITS[field].text()
            text = text.replace("{range}", rng) if "{range}" in text else f"{text}, {rng}"
        else:
            raise ValueError(f"TrialConfig's field {field!r} has neither choices nor bounds: declare its option itself")
        group.add_argument(option_name(field), help=text, **kw)


def trial_values(args: argparse.Namespace, fields) -> dict:
    """``{field: args.field}`` for the options of ``fields`` that were declared."""
    return {f: getattr(args, f) for f in fields if hasattr(args, f)}
