"""The ``run`` command's study (its command line is ``experiments.cli.run``): the run (:mod:`.run`),
its summary files (:mod:`.summary`) and its Rerun recording (:mod:`.recorder`)."""

from .recorder import record_study
from .run import NonFiniteResultError, run_study
from .summary import displacement_outputs, write_summary

__all__ = ["NonFiniteResultError", "displacement_outputs", "record_study", "run_study", "write_summary"]
