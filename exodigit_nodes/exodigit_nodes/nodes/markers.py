"""RViz / Foxglove markers of the glove: exo-digit backbone, finger links, contact-force arrows."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from exodigit_model import GloveModel

ARC_SAMPLES = 8
"""Points drawn along each soft arc."""
FINGER_GAP = 0.012
"""Drawn distance between the exo-digit's base line and the finger's axis, m (cosmetic)."""
FORCE_SCALE = 0.02
"""Length of a contact-force arrow per newton, m/N."""

_EXO_COLOUR = ColorRGBA(r=0.2, g=0.5, b=0.9, a=1.0)
_FINGER_COLOUR = ColorRGBA(r=0.9, g=0.7, b=0.55, a=1.0)
_FORCE_COLOUR = ColorRGBA(r=0.9, g=0.2, b=0.2, a=1.0)


def _marker(namespace: str, ident: int, kind: int, width: float, colour: ColorRGBA) -> Marker:
    marker = Marker(ns=namespace, id=ident, type=kind, action=Marker.ADD, color=colour)
    marker.pose.orientation.w = 1.0
    marker.scale.x = width
    if kind == Marker.ARROW:
        marker.scale.y = 2.0 * width
        marker.scale.z = 3.0 * width
    return marker


class GloveMarkers:
    """A MarkerArray built once and updated from the glove's pose.

    Parameters
    ----------
    model : GloveModel
        Gives the pose (eqs 1-4, 33) at the joint angles and the arcs' lengths
        (docs/spec/model.md §12).
    """

    def __init__(self, model: GloveModel) -> None:
        self.model = model
        rest = model.pose(np.zeros(3), arc_samples=ARC_SAMPLES)
        self.finger_offset = np.array([rest.arcs[0][ARC_SAMPLES // 2][0], FINGER_GAP])
        backbone = _marker('exo_digit', 0, Marker.LINE_STRIP, 0.003, _EXO_COLOUR)
        finger = _marker('finger', 1, Marker.LINE_STRIP, 0.006, _FINGER_COLOUR)
        arrows = [
            _marker('contact_force', 2 + i, Marker.ARROW, 0.001, _FORCE_COLOUR) for i in range(3)
        ]
        self.array = MarkerArray(markers=[backbone, finger, *arrows])

    @staticmethod
    def _backbone(pose) -> list:
        """Base block, then each arc followed by the block it carries, as (x, y) rows."""
        rows = [pose.block_origins[0], pose.block_ends[0]]
        for i in range(3):
            rows.extend(pose.arcs[i])
            rows.extend((pose.block_origins[i + 1], pose.block_ends[i + 1]))
        return rows

    def update(self, angles, forces, stamp, frame_id: str, lengths=None) -> MarkerArray:
        """The markers at joint angles ``angles`` (rad) with contact forces ``forces`` (N).

        ``lengths`` are the soft arcs' bottom-face lengths ℓ_i (m, docs/spec/model.md §12: the
        plant's ``segment_lengths``); the rest lengths when None.
        """
        pose = self.model.pose(angles, lengths=lengths, arc_samples=ARC_SAMPLES)
        backbone, finger, *arrows = self.array.markers
        lines = [
            (backbone, self._backbone(pose)),
            (finger, pose.finger_joints + self.finger_offset),
        ]
        for arrow, start, normal, force in zip(
            arrows, pose.contact_points, pose.contact_normals, forces, strict=True
        ):
            lines.append((arrow, (start, start + normal * (FORCE_SCALE * float(force)))))
        for marker, rows in lines:
            marker.points = [Point(x=float(x), y=float(y)) for x, y in rows]
        for marker in self.array.markers:
            marker.header.stamp = stamp
            marker.header.frame_id = frame_id
        return self.array
