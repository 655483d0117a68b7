"""``exodigit draw``: the finger and the exo-digit at one pressure, to scale (mm).

The exo-digit is drawn from :meth:`GloveModel.pose` at the solved bottom-face lengths ℓ (the
rest lengths unless a segment is extensible, docs/spec/model.md §12): its base block starts at the
origin, the bottom face (strain-limiting layer) is the line the pose gives and the segment
body (height b + h + R) lies on the far side from the finger. The finger hangs under it (the
+y side), its MCP joint under the middle of the MCP soft segment at rest, one link radius below
the layer; contact points, force arrows (on the finger, along the contact normals), joint
angles and, for an extensible glove, the lengths are written on the picture.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..extras import pyplot
from ..physics.model import GloveModel, GlovePose, Solution
from .figures import DPI, JOINT_LABELS

FIGURE_SIZE = (8.0, 6.0)
"""Picture size, inches (800 x 600 pixels at :data:`.figures.DPI`)."""

FINGER_RADIUS = 0.008
"""Drawn half-thickness of the finger links, m (only for the picture)."""

FORCE_ARROW_SCALE = 0.02
"""Drawn length of a 1 N force arrow, m."""


@dataclass(frozen=True)
class Drawing:
    """What a picture shows: the solution, the pose drawn and the caption written on it."""

    solution: Solution
    pose: GlovePose
    caption: str


def caption(solution: Solution, lengths: bool = False) -> str:
    """One line with the pressures (kPa), angles (deg), lengths (mm) and contact forces (N).

    The segments' bottom-face lengths ℓ are written only when ``lengths`` is true (a glove with
    an extensible segment); otherwise they are the constant rest lengths.
    """
    pressure = '/'.join(f'{v / 1e3:g}' for v in solution.pressure)
    angles = ', '.join(
        f'{label} {v:.1f}°' for label, v in zip(JOINT_LABELS, np.degrees(solution.q), strict=True)
    )
    forces = ', '.join(f'{v:.2f}' for v in solution.forces)
    arcs = ', '.join(f'{v * 1e3:.1f}' for v in solution.lengths)
    shown = f'; ℓ = {arcs} mm' if lengths else ''
    return f'p = {pressure} kPa: {angles}{shown}; f = {forces} N'


def _band(line: np.ndarray, normals: np.ndarray, height: float) -> np.ndarray:
    """Closed polygon between ``line`` and ``line - height * normals``."""
    return np.vstack([line, (line - height * normals)[::-1]])


def _normals(line: np.ndarray) -> np.ndarray:
    tangent = np.gradient(line, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    return np.column_stack([-tangent[:, 1], tangent[:, 0]])


def draw(model: GloveModel, pressure, path: Path) -> Drawing:
    """Solve at ``pressure`` (Pa, shape (3,)) and write the picture to ``path`` (PNG)."""
    solution = model.solve(pressure)
    pose = model.pose(solution.q, solution.lengths, arc_samples=24)
    segments = model.params.exo_digit.segments
    heights = [s.base_thickness + s.wall_height + s.outer_radius for s in segments]
    finger_base = np.array(
        [2 * model.params.exo_digit.base_block_half_length + segments[0].arc_length / 2, 0.0]
    ) + np.array([0.0, FINGER_RADIUS])
    plt = pyplot()
    figure, ax = plt.subplots(figsize=FIGURE_SIZE)
    mm = 1e3

    for block in range(4):
        line = np.array([pose.block_origins[block], pose.block_ends[block]])
        height = heights[max(block - 1, 0)]
        polygon = _band(line, _normals(line), height) * mm
        ax.fill(*polygon.T, color='#4a6fa5', alpha=0.9, label='blocks' if block == 0 else None)
    for segment in range(3):
        arc = pose.arcs[segment]
        polygon = _band(arc, _normals(arc), heights[segment]) * mm
        label = 'soft arcs' if segment == 0 else None
        ax.fill(*polygon.T, color='#9ec5e8', alpha=0.8, label=label)
        ax.plot(*(arc * mm).T, color='#1f3b63', linewidth=1)

    joints = (pose.finger_joints + finger_base) * mm
    contacts = (pose.finger_contacts + finger_base) * mm
    ax.plot(*joints.T, '-', color='#d9a07a', linewidth=FINGER_RADIUS * 2 * mm * 2.2, alpha=0.7)
    ax.plot(*joints.T, 'o-', color='#7a4b2a', linewidth=2, label='finger links')
    for joint in range(3):
        x, y = joints[joint]
        ax.annotate(
            f'{JOINT_LABELS[joint]} {np.degrees(solution.q[joint]):.1f}°',
            (x, y),
            textcoords='offset points',
            xytext=(-10, 14),
            ha='right',
            fontsize=10,
            fontweight='bold',
        )
    ax.plot(*(pose.contact_points * mm).T, 'kx', markersize=8, label='contact (exo-digit)')
    ax.plot(*contacts.T, 'ko', markersize=5, label='contact (finger)')
    for i in range(3):
        link = np.array([pose.contact_points[i] * mm, contacts[i]])
        ax.plot(link[:, 0], link[:, 1], 'k:', linewidth=1)
        arrow = pose.contact_normals[i] * solution.forces[i] * FORCE_ARROW_SCALE * mm
        if np.linalg.norm(arrow) > 0.2:
            ax.arrow(*contacts[i], *arrow, color='tab:red', width=0.4, length_includes_head=True)
        ax.annotate(
            f'{solution.forces[i]:.2f} N',
            contacts[i] + arrow,
            textcoords='offset points',
            xytext=(6, 0),
            color='tab:red',
            fontsize=9,
        )

    ax.set_aspect('equal')
    ax.invert_yaxis()
    ax.grid(True, alpha=0.3)
    ax.set_xlabel('x (mm)')
    ax.set_ylabel('y (mm), finger side down')
    text = caption(solution, lengths=model.extensible)
    ax.set_title(text, fontsize=10)
    ax.legend(loc='lower left', fontsize='small')
    if not solution.converged:
        ax.text(0.5, 0.02, 'solver did not converge', transform=ax.transAxes, color='red')
    figure.tight_layout()
    figure.savefig(path, dpi=DPI, metadata={'Title': 'exodigit draw', 'Description': text})
    plt.close(figure)
    return Drawing(solution, pose, text)
