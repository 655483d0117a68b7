"""exodigit_model: quasi-static model of a soft pneumatic exo-digit strapped to a finger.

A ROS-free package (numpy, scipy, PyYAML, numba) implementing docs/model.md: the kinematics of
the exo-digit and the finger, the Yeoh material, pressure and structural torques, the coupled
quasi-static solve and its inverse, the contact-force estimators, the stepper that advances gloves
in time (behind pressure regulators or valves), and the joiner that pairs the samples of a
glove's streams by time.

>>> from exodigit_model import GloveModel, load_params
>>> model = GloveModel(load_params())
>>> solution = model.solve([50e3, 50e3, 50e3])
"""

from .chambers import ChamberSettings
from .compiling import announce_compiles
from .identification import StiffnessFit, fit_stiffness
from .inverse import BatchEstimate, Estimate, Hold
from .joining import Joined, Joiner, join_indices
from .model import BatchSolution, GloveModel, GlovePose, Solution
from .params import (
    JOINT_NAMES,
    PATIENT_PRESETS,
    ExoDigit,
    Finger,
    FingerJoint,
    GloveParams,
    Material,
    ParameterError,
    Segment,
    dump_params,
    load_params,
    params_from_dict,
    patient_file,
)
from .pneumatics import ChamberAir, Pneumatics
from .simulation import ACTUATIONS, GloveSimulation, GloveState, SimulationSettings
from .validity import OutsideModelWarning

__all__ = [
    'ACTUATIONS',
    'JOINT_NAMES',
    'PATIENT_PRESETS',
    'BatchEstimate',
    'BatchSolution',
    'ChamberAir',
    'ChamberSettings',
    'Estimate',
    'ExoDigit',
    'Finger',
    'FingerJoint',
    'GloveModel',
    'GloveParams',
    'GlovePose',
    'GloveSimulation',
    'GloveState',
    'Hold',
    'Joined',
    'Joiner',
    'Material',
    'OutsideModelWarning',
    'ParameterError',
    'Pneumatics',
    'Segment',
    'SimulationSettings',
    'Solution',
    'StiffnessFit',
    'dump_params',
    'fit_stiffness',
    'join_indices',
    'load_params',
    'params_from_dict',
    'patient_file',
]
__version__ = '0.1.0'

announce_compiles()  # one log line when the kernels compile (README, "Compiled model")
