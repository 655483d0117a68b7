"""exodigit_model: quasi-static model of a soft pneumatic exo-digit strapped to a finger.

A ROS-free package (numpy, scipy, PyYAML, numba) implementing docs/spec/model.md, in layers
that each import only from the ones before them (tests/test_model_layers.py):

- base: :mod:`.checks` (parameter checks), :mod:`.extras` (the optional extras),
  :mod:`.kernels` and :mod:`.compiling` (the compiled hot paths);
- :mod:`.physics`: the kinematics of the exo-digit and the finger, the Yeoh material, pressure
  and structural torques, the coupled quasi-static solve and its inverse, the contact-force
  estimators, the chambers' air, populations of patients;
- :mod:`.stepping`: gloves stepped in time behind pressure regulators or valves, and the joiner
  that pairs the samples of a glove's streams by time;
- :mod:`.control`: the built-in controllers, the safety limiter, the valve loop;
- applications: :mod:`.gym` (Gymnasium environments), :mod:`.trials` (virtual-patient trials),
  :mod:`.tools` (the ``exodigit`` command).

The public names below are importable from ``exodigit_model`` itself.

>>> from exodigit_model import GloveModel, load_params
>>> model = GloveModel(load_params())
>>> solution = model.solve([50e3, 50e3, 50e3])
"""

import importlib

EXPORTS = {
    'ACTUATIONS': 'stepping.settings',
    'JOINT_NAMES': 'physics.params',
    'PATIENT_PRESETS': 'physics.params',
    'BatchEstimate': 'physics.inverse',
    'BatchSolution': 'physics.model',
    'ChamberAir': 'physics.pneumatics',
    'ChamberSettings': 'stepping.chambers',
    'Estimate': 'physics.inverse',
    'ExoDigit': 'physics.params',
    'Finger': 'physics.params',
    'FingerJoint': 'physics.params',
    'GloveModel': 'physics.model',
    'GloveParams': 'physics.params',
    'GlovePose': 'physics.model',
    'GloveSimulation': 'stepping.simulation',
    'GloveState': 'stepping.simulation',
    'Hold': 'physics.inverse',
    'Joined': 'stepping.joining',
    'Joiner': 'stepping.joining',
    'Material': 'physics.params',
    'OutsideModelWarning': 'physics.validity',
    'ParameterError': 'physics.params',
    'Pneumatics': 'physics.pneumatics',
    'Segment': 'physics.params',
    'SimulationSettings': 'stepping.settings',
    'Solution': 'physics.model',
    'StiffnessFit': 'physics.identification',
    'dump_params': 'physics.params',
    'fit_stiffness': 'physics.identification',
    'join_indices': 'stepping.joining',
    'load_params': 'physics.params',
    'params_from_dict': 'physics.params',
    'patient_file': 'physics.params',
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
