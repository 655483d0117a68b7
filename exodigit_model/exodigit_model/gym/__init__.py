"""The glove as Gymnasium environments (the ``gym`` extra; docs/gym.md).

Importing this package registers ``exodigit/Glove-v0`` (:class:`~.env.GloveEnv`, one glove) and
``exodigit/GlovePatients-v0`` (:class:`~.vector.GloveVectorEnv`, a population of patients, and
:class:`~.vector.GlovePatientEnv`, one glove on a new patient at every reset);
:mod:`.sb3` adapts the vector environment to Stable-Baselines3 (the ``rl`` extra).
"""

from .env import (
    DEFAULT_SAFETY,
    ENV_ID,
    NODE_SAFETY,
    GloveEnv,
    PolicyController,
    tracking_reward,
)
from .vector import VECTOR_ENV_ID, GlovePatientEnv, GloveVectorEnv

__all__ = [
    'DEFAULT_SAFETY',
    'ENV_ID',
    'NODE_SAFETY',
    'VECTOR_ENV_ID',
    'GloveEnv',
    'GlovePatientEnv',
    'GloveVectorEnv',
    'PolicyController',
    'tracking_reward',
]
