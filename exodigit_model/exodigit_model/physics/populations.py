"""Patient populations: distributions over the patient of docs/spec/model.md §11, sampled by seed.

A population gives each patient parameter of each joint (the fields of :data:`PATIENT_FIELDS`) a
distribution (:mod:`.distributions`) and says how the parameters vary together
(:class:`Correlation`). :meth:`Population.sample` draws patients reproducibly from a seed, as
parameter arrays for a batch and as :class:`~exodigit_model.physics.params.Finger` objects for one
:class:`~exodigit_model.physics.model.GloveModel` each. Populations are YAML files; one per patient
preset ships with the package, centred on it (docs/patients.md). The format, the shipped
populations and their sources: docs/populations.md.

Every sampled joint is valid by construction: the bounds of a population are checked when it is
built, at the two corners of the box they span where FingerJoint's rules are hardest to meet, so
no draw is ever refused or moved.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import cache, cached_property
from importlib import resources
from numbers import Integral
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..checks import (
    ParameterError,
    build_checked,
    check_choice,
    check_keys,
    check_name,
    check_number,
    read_yaml,
    set_field,
)
from .distributions import KINDS, Distribution, Fixed
from .params import PATIENT_PRESETS, Finger, FingerJoint, params_from_dict

ANATOMY = ('name', 'link_half_length')
"""Fields of a FingerJoint that describe the hand, not the patient: taken from a base finger."""

PATIENT_FIELDS = tuple(item.name for item in fields(FingerJoint) if item.name not in ANATOMY)
"""The patient parameters a population draws, per joint (docs/spec/model.md §11)."""

POPULATIONS = PATIENT_PRESETS
"""The populations shipped with the package: one per patient preset, centred on it."""

DRAWS_PER_PATIENT = 1 + 4 * len(PATIENT_FIELDS)
"""Standard normal draws per patient: s, then η_f per field, then ε_f,j per field and joint."""


@cache
def _default_finger() -> Finger:
    return params_from_dict().finger


@dataclass(frozen=True)
class Correlation:
    """How a patient's parameters vary together: a Gaussian copula with one common factor.

    Each parameter f of joint j is made from a latent standard normal value (a higher value gives
    a higher parameter, see :mod:`.distributions`)

        z_f,j = λ_f·s + √(1 − λ_f²)·(√ρ·η_f + √(1 − ρ)·ε_f,j)

    where s (the patient's severity within the population), η_f (the patient's own deviation in
    f, shared by the three joints) and ε_f,j are independent standard normal draws. The latent
    correlation is λ_f·λ_g between two different parameters (at any joints) and
    λ_f² + (1 − λ_f²)·ρ between one parameter at two joints; it is valid for every λ and ρ in
    range. Rank correlations of the parameters: (6/π)·asin(r/2) for a latent correlation r.

    Attributes
    ----------
    joints : float
        ρ, in [0, 1]: how much of what is not severity the three joints share.
    severity : mapping of str to float
        λ_f, in [−1, 1], per field of :data:`PATIENT_FIELDS`: how strongly the parameter rises
        (λ > 0) or falls (λ < 0) with severity; fields left out have 0.
    """

    joints: float = 0.0
    severity: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        joints = check_number('joints', self.joints)
        if not 0.0 <= joints <= 1.0:
            raise ParameterError(f'joints = {joints!r}: must be within [0, 1]')
        check_keys('severity', self.severity, dict.fromkeys(PATIENT_FIELDS))
        severity = {}
        for key, loading in self.severity.items():
            severity[key] = check_number(f'severity.{key}', loading)
            if not -1.0 <= severity[key] <= 1.0:
                raise ParameterError(f'severity.{key} = {loading!r}: must be within [-1, 1]')
        set_field(self, 'joints', joints)
        set_field(self, 'severity', MappingProxyType(severity))

    def latent(self, draws: NDArray) -> NDArray[np.float64]:
        """Latent z_f,j, shape (count, fields, 3), from draws (count, DRAWS_PER_PATIENT)."""
        count, size = len(draws), len(PATIENT_FIELDS)
        severity = draws[:, :1, np.newaxis]
        shared = draws[:, 1 : 1 + size, np.newaxis]
        own = draws[:, 1 + size :].reshape(count, size, 3)
        loading = np.array([self.severity.get(key, 0.0) for key in PATIENT_FIELDS])[:, np.newaxis]
        rho = self.joints
        rest = math.sqrt(rho) * shared + math.sqrt(1.0 - rho) * own
        return loading * severity + np.sqrt(1.0 - loading**2) * rest


def _whole(key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f'{key} = {value!r}: must be a whole number')
    if value < 0:
        raise ValueError(f'{key} = {value!r}: must be >= 0')
    return int(value)


@dataclass(frozen=True)
class Patients:
    """Patients drawn from a population: parameter arrays, and the fingers they make.

    Attributes
    ----------
    population : str
        Name of the population drawn from.
    seed : int
        The seed drawn with.
    arrays : mapping of str to ndarray
        Per field of :data:`PATIENT_FIELDS`, a read-only array of shape (count, 3): patient i,
        joint j (MCP, PIP, DIP), in the field's SI unit.
    base : Finger
        The finger whose names and link lengths every patient keeps.
    """

    population: str
    seed: int
    arrays: Mapping[str, NDArray[np.float64]]
    base: Finger

    def __len__(self) -> int:
        """The number of patients."""
        return len(self.arrays[PATIENT_FIELDS[0]])

    @cached_property
    def fingers(self) -> tuple[Finger, ...]:
        """One validated Finger per patient: ``GloveModel(replace(params, finger=finger))``."""
        return tuple(
            Finger(
                joints=tuple(
                    replace(
                        joint, **{key: float(self.arrays[key][i, j]) for key in PATIENT_FIELDS}
                    )
                    for j, joint in enumerate(self.base.joints)
                )
            )
            for i in range(len(self))
        )


@dataclass(frozen=True)
class Population:
    """A set of patients: a distribution per parameter and joint, and how they vary together.

    Attributes
    ----------
    name : str
        Label of the population.
    joints : tuple of mapping
        Three (MCP, PIP, DIP), each mapping every field of :data:`PATIENT_FIELDS` to a
        :data:`~.distributions.Distribution` in the field's SI unit.
    correlation : Correlation
        How the parameters vary together (default: independently).
    description : str
        Who the population describes.

    Raises
    ------
    ParameterError
        If a joint lacks a field, or if the bounds allow a joint that FingerJoint refuses
        (e.g. a rest angle that can fall outside the range of motion).
    """

    name: str
    joints: tuple[Mapping[str, Distribution], ...]
    correlation: Correlation = field(default_factory=Correlation)
    description: str = ''

    def __post_init__(self) -> None:
        set_field(self, 'name', check_name('name', self.name))
        if not isinstance(self.description, str):
            raise ParameterError(f'description = {self.description!r}: must be a string')
        joints = tuple(MappingProxyType(dict(joint)) for joint in self.joints)
        if len(joints) != 3:
            raise ParameterError(
                f'joints has {len(joints)} entries: must be exactly 3 (MCP, PIP, DIP)'
            )
        for i, joint in enumerate(joints):
            if set(joint) != set(PATIENT_FIELDS):
                raise ParameterError(
                    f'joints[{i}] has fields {sorted(joint)}: must have exactly '
                    f'{", ".join(PATIENT_FIELDS)}'
                )
            _check_corners(i, joint)
        set_field(self, 'joints', joints)

    def sample(self, count: int, seed: int, *, base: Finger | None = None) -> Patients:
        """Draw ``count`` patients from ``seed``, the same ones bit for bit for the same seed.

        Patient i is made from the i-th block of :data:`DRAWS_PER_PATIENT` standard normal draws
        of numpy's default generator (PCG64) seeded with ``seed``, so it does not depend on
        ``count``: the first patients of a larger sample are those of a smaller one.

        Parameters
        ----------
        count : int
            Number of patients, >= 0.
        seed : int
            Seed of the generator, >= 0.
        base : Finger, optional
            Finger whose joint names and link lengths the patients keep (e.g. another finger of
            the hand); default: the model's default finger.

        Returns
        -------
        Patients
        """
        count, seed = _whole('count', count), _whole('seed', seed)
        draws = np.random.default_rng(seed).standard_normal((count, DRAWS_PER_PATIENT))
        latent = self.correlation.latent(draws)
        arrays = {}
        for f, key in enumerate(PATIENT_FIELDS):
            values = np.stack(
                [joint[key].values(latent[:, f, j]) for j, joint in enumerate(self.joints)],
                axis=1,
            )
            values.flags.writeable = False
            arrays[key] = values
        base = _default_finger() if base is None else base
        return Patients(self.name, seed, MappingProxyType(arrays), base)


def _check_corners(index: int, joint: Mapping[str, Distribution]) -> None:
    """Refuse bounds that allow a joint FingerJoint refuses.

    FingerJoint's rules are lower limits on single fields (>= 0, > 0) and the order
    rom_min < rom_max, rom_min <= rest_angle <= rom_max. Over the box the bounds span they are
    hardest to meet with every field at its low bound but rom_min at its high one, and there
    again with rest_angle at its high bound: valid at both corners means valid everywhere.
    """
    lowest = {key: 'low' for key in joint} | {'rom_min': 'high'}
    for corner in (lowest, lowest | {'rest_angle': 'high'}):
        values = {key: getattr(joint[key], bound) for key, bound in corner.items()}
        try:
            replace(_default_finger().joints[index], **values)
        except ParameterError as error:
            key = str(error).split(' = ', 1)[0]
            where = key if isinstance(joint[key], Fixed) else f'{key}.{corner[key]}'
            raise ParameterError(
                f'joints[{index}].{where}: a patient at the bounds would break a rule of the '
                f'model: {error}'
            ) from None


def population_file(name: str) -> Path:
    """The path of a shipped population (one of :data:`POPULATIONS`), e.g. to copy it.

    Raises
    ------
    ParameterError
        For a name that is not shipped.
    """
    if name not in POPULATIONS:
        raise ParameterError(f'population {name!r}: unknown (shipped: {", ".join(POPULATIONS)})')
    return Path(str(resources.files('exodigit_model').joinpath('populations', f'{name}.yaml')))


def load_population(source: str | Path) -> Population:
    """A shipped population by name, or a population file (format: docs/populations.md).

    Parameters
    ----------
    source : str or Path
        One of :data:`POPULATIONS`, or the path of a YAML population file.

    Returns
    -------
    Population

    Raises
    ------
    ParameterError
        Naming the file, the key (e.g. ``joints[1].stiffness.sd``) and the rule broken.
    """
    path = population_file(source) if source in POPULATIONS else Path(source)
    try:
        text = path.read_text('utf-8')
    except OSError as error:
        raise ParameterError(
            f'{path}: cannot read population file ({error.strerror}; shipped populations: '
            f'{", ".join(POPULATIONS)})'
        ) from None
    try:
        return _population(read_yaml(text, str(path)), path.stem)
    except ParameterError as error:
        raise ParameterError(f'{path}: {error}') from None


def _population(data: Any, stem: str) -> Population:
    """A population from a file's contents; ``name`` defaults to the file's stem."""
    check_keys('', data, dict.fromkeys(('name', 'description', 'joints', 'correlation')))
    joints = data.get('joints')
    if not isinstance(joints, list) or len(joints) != 3:
        count = len(joints) if isinstance(joints, list) else repr(joints)
        raise ParameterError(f'joints = {count}: must be a list of exactly 3 (MCP, PIP, DIP)')
    correlation = data.get('correlation', {})
    check_keys('correlation', correlation, dict.fromkeys(('joints', 'severity')))
    return Population(
        name=data.get('name', stem),
        description=data.get('description', ''),
        joints=tuple(
            _joint(f'joints[{i}]', raw, default)
            for i, (raw, default) in enumerate(zip(joints, _default_finger().joints, strict=True))
        ),
        correlation=build_checked(Correlation, 'correlation', correlation),
    )


def _joint(path: str, raw: Any, default: FingerJoint) -> dict[str, Distribution]:
    """One joint's distributions; a field left out is fixed at the model's default."""
    check_keys(path, raw, dict.fromkeys(PATIENT_FIELDS))
    return {
        key: _distribution(f'{path}.{key}', raw[key])
        if key in raw
        else Fixed(getattr(default, key))
        for key in PATIENT_FIELDS
    }


def _distribution(path: str, raw: Any) -> Distribution:
    """A bare number (fixed), or a mapping of ``kind`` and that kind's keys."""
    if not isinstance(raw, Mapping):
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            raise ParameterError(
                f'{path} = {raw!r}: must be a number (a fixed value) or a distribution '
                f'(a mapping with kind: {", ".join(KINDS)})'
            )
        return Fixed(check_number(path, raw))
    kind = raw.get('kind')
    check_choice(f'{path}.kind', kind, tuple(KINDS))
    keys = [item.name for item in fields(KINDS[kind])]
    check_keys(path, raw, dict.fromkeys(['kind', *keys]))
    missing = [key for key in keys if key not in raw]
    if missing:
        raise ParameterError(
            f'{path}.{missing[0]}: missing (a {kind} distribution needs {", ".join(keys)})'
        )
    return build_checked(KINDS[kind], path, {key: raw[key] for key in keys})
