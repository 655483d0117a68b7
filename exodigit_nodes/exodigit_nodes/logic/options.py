"""Rules a glove's or a hand's options follow, checked before anything starts (no ROS)."""

from __future__ import annotations

import re

NAMESPACE_PATTERN = re.compile(r'^(/[A-Za-z][A-Za-z0-9_]*)+$')
"""A namespace every node of a glove or hand can take: absolute, each name a letter first."""


class UsageError(ValueError):
    """A command-line value a runner refuses before starting anything."""


def check_namespace(namespace: str, examples: str) -> None:
    """Refuse a ``--namespace`` a node would refuse once started; ``examples``: good values."""
    if not NAMESPACE_PATTERN.match(namespace):
        raise UsageError(
            f'--namespace {namespace!r}: must be absolute, each name starting with a letter '
            f'followed by letters, digits or underscores, e.g. {examples}'
        )


NOMINAL_PATIENT = 'nominal'
"""``--patient`` value for the model files alone (their nominal finger)."""


def with_patient(files: list[str], patient: str) -> list[str]:
    """A plant's model files: ``files``, then the patient (a preset's or a YAML) merged over."""
    from exodigit_model import PATIENT_PRESETS, patient_file

    if patient == NOMINAL_PATIENT:
        return list(files)
    return [*files, str(patient_file(patient) if patient in PATIENT_PRESETS else patient)]
