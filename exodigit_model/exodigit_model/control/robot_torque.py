r"""(J_R*)ᵀ f: the joint torque that contact forces f put on the exo-digit (docs/spec/model.md §7).

The force mode's feed-forward p = B_R⁻¹((J_R*)ᵀ f* − τ_s(q)) needs it at the measured angles of
every glove at every step. One glove takes J_R* from :meth:`GloveModel.contact_jacobians`, as
``pressure_command`` always has. A batch runs :func:`robot_contact_torques` over its rows: the
robot-side twin of the finger-side kernel ``contact_torques`` (:mod:`exodigit_model.kernels.
inverse`), compiled the same way (:mod:`exodigit_model.kernels.jit`), with the same kinematics
(``robot_terms``) and product (``transpose_product``), which rounds as numpy's ``J.T @ f``
does: tests/test_control_batch.py checks that the rows equal the one-glove values bit for bit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..kernels.constants import unpack
from ..kernels.jit import kernel
from ..kernels.kinematics import robot_terms
from ..kernels.linear import transpose_product
from ..kernels.workspace import workspace
from ..model import GloveModel, as_joint_rows


@kernel
def robot_contact_torques(packed, angles, forces):
    """(J_R*)ᵀ f per row of angles (rad) and contact forces (N), (N, 3): N·m, (N, 3)."""
    glove, work = unpack(packed), workspace()
    torque = np.empty(angles.shape)
    for r in range(angles.shape[0]):
        robot_terms(angles[r], glove.arc_lengths, glove.block_half_lengths, False, work)
        transpose_product(work.j_robot, forces[r], torque[r])
    return torque


def robot_contact_torque(
    model: GloveModel, q: NDArray[np.float64], forces: ArrayLike
) -> NDArray[np.float64]:
    """(J_R*)ᵀ f of ``model``'s exo-digit at rest-length segments, N·m, shaped like ``q``.

    Parameters
    ----------
    model : GloveModel
        The glove (its finger is not used).
    q : ndarray, shape (3,) or (N, 3)
        Joint angles, rad: one glove, or one row per glove.
    forces : array_like, shape (3,) or that of ``q``
        Contact forces, N; shape (3,) gives every row the same.

    Raises
    ------
    ValueError
        If ``q`` is not finite or not of shape (3,) or (N, 3).
    """
    if np.ndim(q) == 1:
        j_robot, _ = model.contact_jacobians(q)
        return j_robot.T @ forces
    angles = np.ascontiguousarray(as_joint_rows('q', q))
    rows = np.ascontiguousarray(np.broadcast_to(forces, angles.shape), dtype=float)
    return robot_contact_torques(model.packed, angles, rows)
