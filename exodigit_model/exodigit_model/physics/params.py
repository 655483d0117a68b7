"""Glove parameters: frozen dataclasses, validated on construction, loaded from YAML (§10).

Every length is in metres, every stress coefficient in pascals and every stiffness in N·m/rad.
A YAML file is merged over the defaults shipped with the package (``default_params.yaml``), so a
file only needs the keys it changes. Any rule broken raises :class:`ParameterError` (a
``ValueError``) whose message names the key, the value and the rule.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from ..checks import (
    ParameterError,
    build_checked,
    check_keys,
    check_name,
    check_non_negative,
    check_number,
    check_positive,
    check_three,
    read_yaml,
    set_field,
)
from .pneumatics import ChamberAir, Pneumatics

JOINT_NAMES = ('mcp', 'pip', 'dip')
"""The three joints, always in this order (docs/spec/model.md §1)."""


@dataclass(frozen=True)
class Material:
    """Yeoh third-order hyperelastic coefficients (eq 22), Pa.

    W = C1 (I1 - 3) + C2 (I1 - 3)^2 + C3 (I1 - 3)^3. C1 is the small-strain shear modulus
    divided by two and must be positive; C2 and C3 may have either sign.
    """

    c1: float
    c2: float = 0.0
    c3: float = 0.0

    def __post_init__(self) -> None:
        set_field(self, 'c1', check_positive('c1', self.c1, 'Pa'))
        set_field(self, 'c2', check_number('c2', self.c2))
        set_field(self, 'c3', check_number('c3', self.c3))


@dataclass(frozen=True)
class Segment:
    """One soft segment of the exo-digit and the semi-rigid block distal to it (Fig. 1-2).

    Attributes
    ----------
    name : str
        Label of the joint the segment drives.
    arc_length : float
        ℓ̂_i, rest arc length of the segment's bottom face, m (its length with an inextensible
        layer).
    inner_radius : float
        r0_i, radius of the half-bellow cavity, m.
    wall_thickness : float
        t_i, thickness of the side walls and of the arch, m.
    wall_height : float
        h_i, height of the straight side walls, m.
    base_thickness : float
        b_i, thickness of the inextensible base layer, m.
    block_half_length : float
        d_i, half the length of the block distal to the segment (its centre of mass), m.
    layer_axial_stiffness : float
        E_L,i, axial stiffness of the strain-limiting bottom layer, N (force per unit strain,
        docs/spec/model.md §12); ``inf`` = inextensible (the paper's constant arc length), 0 = no
        layer.
    """

    name: str
    arc_length: float
    inner_radius: float
    wall_thickness: float
    wall_height: float
    base_thickness: float
    block_half_length: float
    layer_axial_stiffness: float

    def __post_init__(self) -> None:
        set_field(self, 'name', check_name('name', self.name))
        for field in fields(self)[1:-1]:
            set_field(self, field.name, check_positive(field.name, getattr(self, field.name), 'm'))
        stiffness = self.layer_axial_stiffness
        if stiffness != math.inf:  # .inf is the paper's inextensible layer
            stiffness = check_non_negative('layer_axial_stiffness', stiffness, 'N, or .inf')
        set_field(self, 'layer_axial_stiffness', float(stiffness))

    @property
    def extensible(self) -> bool:
        """Whether the bottom face stretches (a finite ``layer_axial_stiffness``)."""
        return self.layer_axial_stiffness != math.inf

    @property
    def outer_radius(self) -> float:
        """R = r0 + t, the outer radius of the arch, m."""
        return self.inner_radius + self.wall_thickness

    @property
    def height(self) -> float:
        """Height of the cross-section above the bottom face, b + h + r0 + t, m."""
        return self.base_thickness + self.wall_height + self.outer_radius


@dataclass(frozen=True)
class ExoDigit:
    """The soft exo-digit: a base block and three segments (MCP, PIP, DIP).

    Attributes
    ----------
    base_block_half_length : float
        d0, half the length of the fixed base block, m.
    segments : tuple of Segment
        Exactly three, in joint order.
    """

    base_block_half_length: float
    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        set_field(
            self,
            'base_block_half_length',
            check_positive('base_block_half_length', self.base_block_half_length, 'm'),
        )
        set_field(self, 'segments', check_three('segments', self.segments, Segment))


@dataclass(frozen=True)
class FingerJoint:
    """One finger joint and the link distal to it: the patient of docs/spec/model.md §11.

    With the defaults of ``default_params.yaml`` (the one place they live) the joint is the
    paper's linear torsional spring (eq 32).

    Attributes
    ----------
    name : str
        Joint label.
    link_half_length : float
        ℓ_i, half the length of the link (the contact sits at its middle), m.
    stiffness : float
        k_i, passive torsional stiffness about the rest angle, N·m/rad (0 = no finger).
    rest_angle : float
        q_r,i, where the relaxed finger rests, rad (flexion positive); within the range of motion.
    rom_torque : float
        a_i, size of the range-of-motion stiffening e(q) of eq 11.2, N·m (0 = off).
    rom_sharpness : float
        β_i, how steeply e(q) rises towards the ends of the range, 1/rad.
    rom_min, rom_max : float
        q_min,i < q_max,i, the passive range of motion, rad.
    damping : float
        c_i, viscous joint damping, N·m·s/rad.
    spasticity : float
        g_f,i, velocity-dependent resistance of the flexors to extension (eq 11.3), N·m·s/rad.
    extensor_spasticity : float
        g_e,i, the same of the extensors, resisting flexion, N·m·s/rad.
    spasticity_threshold : float
        v_t,i, joint speed above which the spastic resistance acts, rad/s.
    """

    name: str
    link_half_length: float
    stiffness: float
    rest_angle: float
    rom_min: float
    rom_max: float
    rom_torque: float
    rom_sharpness: float
    damping: float
    spasticity: float
    extensor_spasticity: float
    spasticity_threshold: float

    def __post_init__(self) -> None:
        set_field(self, 'name', check_name('name', self.name))
        set_field(
            self,
            'link_half_length',
            check_positive('link_half_length', self.link_half_length, 'm'),
        )
        for key, unit in (
            ('stiffness', 'N·m/rad'),
            ('rom_torque', 'N·m'),
            ('damping', 'N·m·s/rad'),
            ('spasticity', 'N·m·s/rad'),
            ('extensor_spasticity', 'N·m·s/rad'),
        ):
            set_field(self, key, check_non_negative(key, getattr(self, key), unit))
        for key, unit in (('rom_sharpness', '1/rad'), ('spasticity_threshold', 'rad/s')):
            set_field(self, key, check_positive(key, getattr(self, key), unit))
        for key in ('rom_min', 'rom_max', 'rest_angle'):
            set_field(self, key, check_number(key, getattr(self, key)))
        if not self.rom_min < self.rom_max:
            raise ParameterError(
                f'rom_min = {self.rom_min!r}: must be below rom_max = {self.rom_max!r} (rad)'
            )
        if not self.rom_min <= self.rest_angle <= self.rom_max:
            raise ParameterError(
                f'rest_angle = {self.rest_angle!r}: must lie within the range of motion '
                f'[rom_min, rom_max] = [{self.rom_min!r}, {self.rom_max!r}] rad'
            )


@dataclass(frozen=True)
class Finger:
    """The anthropomorphic finger: three hinge joints with torsional springs."""

    joints: tuple[FingerJoint, ...]

    def __post_init__(self) -> None:
        set_field(self, 'joints', check_three('joints', self.joints, FingerJoint))


@dataclass(frozen=True)
class GloveParams:
    """Everything the model needs: material, exo-digit geometry, finger and the chambers' air."""

    material: Material
    exo_digit: ExoDigit
    finger: Finger
    pneumatics: Pneumatics

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict in the YAML layout of docs/spec/model.md §10 (lists, not tuples)."""
        data = asdict(self)
        data['exo_digit']['segments'] = list(data['exo_digit']['segments'])
        data['finger']['joints'] = list(data['finger']['joints'])
        data['pneumatics']['chambers'] = list(data['pneumatics']['chambers'])
        return data


def _merge(path: str, defaults: Any, override: Any) -> Any:
    """Merge ``override`` over ``defaults`` key by key; lists of three merge item by item."""
    if isinstance(defaults, dict):
        if override is None:
            return defaults
        check_keys(path, override, defaults)
        return {
            key: _merge(f'{path}.{key}' if path else key, value, override.get(key))
            for key, value in defaults.items()
        }
    if isinstance(defaults, list):
        if override is None:
            return defaults
        if not isinstance(override, list) or len(override) != len(defaults):
            count = len(override) if isinstance(override, list) else type(override).__name__
            raise ParameterError(
                f'{path} has {count} entries: must be a list of exactly {len(defaults)} '
                '(MCP, PIP, DIP)'
            )
        return [
            _merge(f'{path}[{i}]', item, over)
            for i, (item, over) in enumerate(zip(defaults, override, strict=True))
        ]
    return defaults if override is None else override


def params_from_dict(data: Mapping[str, Any] | None = None) -> GloveParams:
    """Build validated parameters from a nested dict merged over the defaults.

    Parameters
    ----------
    data : mapping, optional
        Keys as in docs/spec/model.md §10-11; missing keys take the defaults.

    Returns
    -------
    GloveParams

    Raises
    ------
    ParameterError
        If a key is unknown, a count is wrong or a value breaks its rule.
    """
    return _params(_merge('', _default_dict(), {} if data is None else data))


def _params(merged: Mapping[str, Any]) -> GloveParams:
    exo, finger, pneumatics = merged['exo_digit'], merged['finger'], merged['pneumatics']
    segments = tuple(
        build_checked(Segment, f'exo_digit.segments[{i}]', s)
        for i, s in enumerate(exo['segments'])
    )
    joints = tuple(
        build_checked(FingerJoint, f'finger.joints[{i}]', j)
        for i, j in enumerate(finger['joints'])
    )
    chambers = tuple(
        build_checked(ChamberAir, f'pneumatics.chambers[{i}]', c)
        for i, c in enumerate(pneumatics['chambers'])
    )
    return GloveParams(
        material=build_checked(Material, 'material', merged['material']),
        exo_digit=build_checked(ExoDigit, 'exo_digit', exo, segments=segments),
        finger=build_checked(Finger, 'finger', finger, joints=joints),
        pneumatics=build_checked(Pneumatics, 'pneumatics', pneumatics, chambers=chambers),
    )


def _default_dict() -> dict[str, Any]:
    text = resources.files('exodigit_model').joinpath('default_params.yaml').read_text('utf-8')
    return read_yaml(text, 'default_params.yaml')


PATIENT_PRESETS = ('healthy', 'stroke_mild', 'stroke_moderate', 'stroke_severe')
"""The patient files shipped with the package (docs/spec/model.md §11; sources inside)."""


def patient_file(name: str) -> Path:
    """The path of a shipped patient preset (a parameter file holding only ``finger``).

    Raises
    ------
    ParameterError
        For a name that is not one of :data:`PATIENT_PRESETS`.
    """
    if name not in PATIENT_PRESETS:
        raise ParameterError(
            f'patient {name!r}: unknown preset (known: {", ".join(PATIENT_PRESETS)})'
        )
    return Path(str(resources.files('exodigit_model').joinpath('patients', f'{name}.yaml')))


ParamsFiles = str | Path | Sequence[str | Path] | None
"""One parameter file, several (merged in order), or none (the defaults)."""


def params_files(paths: ParamsFiles) -> list[Path]:
    """``paths`` as a list of files: one path, a sequence of them, or none ('' is none)."""
    if paths is None:
        return []
    if isinstance(paths, str | Path):
        paths = [paths]
    return [Path(path) for path in paths if str(path) != '']


def load_params(path: ParamsFiles = None) -> GloveParams:
    """The defaults with YAML files merged over them in order (docs/spec/model.md §10).

    Parameters
    ----------
    path : str, Path or sequence of them, optional
        Parameter file, or files merged in order (e.g. a glove, then a patient: later files
        change only the keys they hold). ``None`` (or empty strings) gives the built-in
        defaults.

    Returns
    -------
    GloveParams

    Raises
    ------
    ParameterError
        With the file name, the key, the value and the rule, if anything is wrong.
    """
    merged = _default_dict()
    files = params_files(path)
    for file in files:
        try:
            text = file.read_text('utf-8')
        except OSError as error:
            raise ParameterError(
                f'{file}: cannot read parameter file ({error.strerror})'
            ) from None
        try:
            merged = _merge('', merged, read_yaml(text, str(file)))
        except ParameterError as error:
            raise ParameterError(f'{file}: {error}') from None
    try:
        return _params(merged)
    except ParameterError as error:
        where = ' + '.join(str(file) for file in files)
        raise ParameterError(f'{where}: {error}' if where else str(error)) from None


def dump_params(params: GloveParams, path: str | Path) -> None:
    """Write ``params`` as a YAML file that :func:`load_params` reads back unchanged."""
    header = '# exodigit glove parameters, SI units (m, Pa, N·m/rad); see docs/spec/model.md §10\n'
    body = yaml.safe_dump(params.to_dict(), sort_keys=False, allow_unicode=True)
    Path(path).write_text(header + body, 'utf-8')
