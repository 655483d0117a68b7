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

import importlib

EXPORTS = {
    'ACTUATIONS': 'settings',
    'JOINT_NAMES': 'params',
    'PATIENT_PRESETS': 'params',
    'BatchEstimate': 'inverse',
    'BatchSolution': 'model',
    'ChamberAir': 'pneumatics',
    'ChamberSettings': 'chambers',
    'Estimate': 'inverse',
    'ExoDigit': 'params',
    'Finger': 'params',
    'FingerJoint': 'params',
    'GloveModel': 'model',
    'GloveParams': 'params',
    'GlovePose': 'model',
    'GloveSimulation': 'simulation',
    'GloveState': 'simulation',
    'Hold': 'inverse',
    'Joined': 'joining',
    'Joiner': 'joining',
    'Material': 'params',
    'OutsideModelWarning': 'validity',
    'ParameterError': 'params',
    'Pneumatics': 'pneumatics',
    'Segment': 'params',
    'SimulationSettings': 'settings',
    'Solution': 'model',
    'StiffnessFit': 'identification',
    'dump_params': 'params',
    'fit_stiffness': 'identification',
    'join_indices': 'joining',
    'load_params': 'params',
    'params_from_dict': 'params',
    'patient_file': 'params',
}
"""The package's public names and the module of each.

They are imported on first use (PEP 562), so that a process that needs only the parameters,
the joiner or the controllers (a recorder, a runner, ``pressure_command``) never imports numba
and its compiled kernels: about 0.45 s of CPU and 100 MB per process (docs/compiled.md).
"""

__all__ = sorted(EXPORTS)
__version__ = '0.1.0'


def __getattr__(name: str) -> object:
    """Import the module of a public name on first use."""
    try:
        module = EXPORTS[name]
    except KeyError:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}') from None
    value = getattr(importlib.import_module(f'.{module}', __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The module's attributes with the public names not imported yet."""
    return sorted(set(globals()) | set(EXPORTS))
