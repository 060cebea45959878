"""The perception theories, one module each, found through a registry by ``TrialConfig.model``.

``REGISTRY`` maps each name to its ``Theory`` (``base``): ``observer`` (Bayesian inference,
``observer``), ``population`` (a gain field on the cortical map, ``population``), ``paper`` (the
paper's set time course, ``paper``) and ``mechanistic`` (the composite of switchable ingredients,
``mechanistic``). ``theory(name)`` returns one; a new theory is a module that calls ``register``.
"""

from __future__ import annotations

from .base import Theory

__all__ = ["Theory", "REGISTRY", "register", "theory"]

#: name -> the registered theory
REGISTRY: dict[str, Theory] = {}


def register(t: Theory) -> Theory:
    """Add ``t`` to ``REGISTRY`` under ``t.name`` (ValueError if the name is taken or empty)."""
    if not t.name or t.name in REGISTRY:
        raise ValueError(f"a theory needs a new, non-empty name; got {t.name!r}")
    REGISTRY[t.name] = t
    return t


def theory(name: str) -> Theory:
    """The registered theory called ``name``; ValueError naming the registered ones otherwise."""
    try:
        return REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(f"no perception theory {name!r}; registered: {', '.join(REGISTRY)}") from None


from . import mechanistic, observer, paper, population  # noqa: E402,F401  (each registers itself)
