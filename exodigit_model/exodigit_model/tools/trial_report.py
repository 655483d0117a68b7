"""A trial's report: a CSV per patient, a JSON summary and the figures a person looks at first.

docs/trials.md, "Report". :func:`write_report` writes into a new (or empty) folder:

- ``patients.csv``: one row per patient: ``patient`` (its index), the patient's sampled
  parameters (``field.joint``, SI, :data:`~.populations.PATIENT_FIELDS`) and every metric
  column (:func:`~.metrics.column_names`);
- ``summary.json``: the spec, the outcome (status, message), the percentiles and worst patients
  of every metric (:func:`~.aggregates.summarize`), each rule with its result, and the patient
  the time-series figure shows;
- ``distributions.png``: histograms over the patients of the main metrics, the force limit
  marked;
- ``worst_patient.png``: that patient's session (its shard run again): angles against the
  targets, pressures and commands, contact forces against the force limit;
- ``rom.png``: the range of motion reached per joint (box plots) against the target's and the
  functional range of motion.

The figures need matplotlib (the ``tools`` extra), imported only when they are drawn.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from ..physics.params import JOINT_NAMES
from ..physics.populations import PATIENT_FIELDS
from ..trials.metrics import column_names
from ..trials.trial import PatientRecord, TrialResult, record_patient

FILES = ('patients.csv', 'summary.json')
"""The report's data files."""

FIGURES = ('distributions.png', 'worst_patient.png', 'rom.png')
"""The report's figures."""


def parameter_columns() -> tuple[str, ...]:
    """The patient-parameter columns of ``patients.csv``: ``field.joint`` for every field."""
    return tuple(f'{key}.{joint}' for key in PATIENT_FIELDS for joint in JOINT_NAMES)


def write_report(
    result: TrialResult,
    out: str | Path,
    *,
    figures: bool = True,
    record: PatientRecord | None = None,
) -> list[Path]:
    """Write the report of ``result`` into the folder ``out`` (made if missing).

    Parameters
    ----------
    result : TrialResult
        The trial's outcome.
    out : str or Path
        A folder that does not exist yet or is empty: a report never mixes with another's
        files.
    figures : bool
        Whether to draw the figures (needs matplotlib; the worst patient's shard is run again
        unless ``record`` is given).
    record : PatientRecord, optional
        The session of the patient the report shows (``result.worst_patient()``), where the
        engine kept it: a ROS node controller's trial cannot be run again in process
        (``KitEngine.records`` of exodigit_nodes).

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ValueError
        If ``out`` is a file or a folder that is not empty, or ``record`` is another
        patient's.
    """
    folder = Path(out)
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise ValueError(f'{folder}: exists and is not an empty folder (a report needs a new one)')
    worst = result.worst_patient()
    if record is not None and record.patient != worst:
        raise ValueError(f'record: patient {record.patient}, but the report shows patient {worst}')
    if figures:
        from ..extras import pyplot

        pyplot()  # fails before anything is written when matplotlib is missing
    folder.mkdir(parents=True, exist_ok=True)
    written = [write_patients(result, folder / FILES[0]), folder / FILES[1]]
    written[1].write_text(json.dumps(summary_document(result, worst), indent=2) + '\n')
    if figures:
        from .trial_figures import distribution_figure, rom_figure, time_series_figure

        distribution_figure(result, folder / FIGURES[0])
        if record is None:
            record = record_patient(result.spec, worst)
        time_series_figure(record, result, folder / FIGURES[1])
        rom_figure(result, folder / FIGURES[2])
        written += [folder / name for name in FIGURES]
    return written


def write_patients(result: TrialResult, path: Path) -> Path:
    """``patients.csv``: index, sampled parameters and every metric column per patient."""
    parameters = [
        result.patients.arrays[key][:, j]
        for key in PATIENT_FIELDS
        for j in range(len(JOINT_NAMES))
    ]
    metrics = list(result.metrics.columns().values())
    with path.open('w', newline='') as file:
        writer = csv.writer(file)
        writer.writerow(('patient', *parameter_columns(), *column_names()))
        for i, row in enumerate(np.column_stack(parameters + metrics).tolist()):
            writer.writerow((i, *row))
    return path


def summary_document(result: TrialResult, worst: int) -> dict[str, Any]:
    """What ``summary.json`` holds (plain values)."""
    return {
        'spec': result.spec.summary(),
        'status': result.status,
        'message': result.message,
        'summary': result.summary,
        'rules': [
            {
                'rule': str(outcome.rule),
                'passed': outcome.passed,
                'status': outcome.status,
                'held': outcome.held,
                'patients': outcome.patients,
                'worst_patient': outcome.worst_patient,
                'worst_value': outcome.worst_value,
                'worst_joint': outcome.worst_joint,
                'message': outcome.message,
            }
            for outcome in result.rules
        ],
        'worst_patient': worst,
    }
