"""What the view draws besides the robot: the eye (translucent) and its retina, the trocar
ring at its radius, the labelled points, the tip trace coloured by RCM deviation, and per
record the needle, the RCM point p(lambda) and the commanded tip. Robot base frame, [m].
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.scene.record import SceneRecord
from rcmplan.view import colors
from rcmplan.view.needle import segments
from rcmplan.view.trace import Trace

RING_POINTS = 48


class SceneDrawing:
    """The static scene of one eye and the per-record markers.

    Args:
        scene: A viser SceneApi. record: The eye, trocar and points.
        marker_radius: Radius of the point markers in [m] (default: a fiftieth of the eye's).
    """

    def __init__(self, scene: Any, record: SceneRecord, marker_radius: float | None = None):
        self.scene, self.record = scene, record
        r = marker_radius or record.eye_radius / 50.0
        # Everything fixed to the eye hangs from one frame, moved by `show`'s `eye_offset` (a
        # subretinal episode's whole-eye motion carries the trocar with it).
        self.eye = scene.add_frame("/eye", show_axes=False)
        self._eye_offset = (0.0, 0.0, 0.0)
        # The eye wall as a wire globe and the retina as the far side of the inner sphere (what
        # one sees through the vitreous): neither hides the needle or the other.
        scene.add_icosphere("/eye/sclera", radius=record.eye_radius, color=colors.EYE,
                            wireframe=True, opacity=0.35, subdivisions=2,
                            position=record.eye_center)  # fmt: skip
        scene.add_icosphere("/eye/retina", radius=record.retina_radius, color=colors.RETINA,
                            opacity=0.45, side="back", position=record.eye_center)  # fmt: skip
        scene.add_line_segments("/eye/trocar", segments(trocar_ring(record)), colors.TROCAR,
                                thickness=3.0, thickness_units="screen")  # fmt: skip
        for name, p in record.labelled_points().items():
            scene.add_icosphere(f"/eye/points/{name}", radius=r, color=colors.TARGET, position=p)
            scene.add_label(f"/eye/points/{name}/label", name, position=(0.0, 0.0, 0.0))
        self.needle = scene.add_line_segments(
            "/needle", np.zeros((1, 2, 3)), colors.NEEDLE, thickness=4.0, thickness_units="screen"
        )
        self.rcm = scene.add_icosphere("/rcm", radius=r, color=colors.RCM_POINT)
        self.target = scene.add_icosphere("/target", radius=0.6 * r, color=colors.TARGET,
                                          wireframe=True)  # fmt: skip

    def show_trace(self, name: str, trace: Trace, scale: float) -> Any:
        """A tip trace (`trace.simplify_trace`), each segment coloured by its RCM deviation
        against `scale` [m]."""
        if len(trace.deviation) == 0:
            return None
        rgb = colors.deviation_colors(trace.deviation, scale)
        return self.scene.add_line_segments(
            name, trace.segments, np.repeat(rgb[:, None, :], 2, axis=1), thickness=2.0,
            thickness_units="screen",
        )  # fmt: skip

    def show(
        self,
        needle: FloatArray,
        rcm: FloatArray,
        target: FloatArray,
        eye_offset: FloatArray | None = None,
    ) -> None:
        """Place the needle (polyline (k, 3)), the RCM point and the commanded tip (hidden
        when NaN: free space, or no target), and the eye `eye_offset` [m] from where the record
        has it (default: not moved)."""
        self.needle.points = segments(needle)
        x, y, z = (0.0, 0.0, 0.0) if eye_offset is None else map(float, eye_offset)
        offset = (x, y, z)
        if offset != self._eye_offset:  # a message to every client only when it moves
            self.eye.position = self._eye_offset = offset
        for handle, p in ((self.rcm, rcm), (self.target, target)):
            shown = bool(np.all(np.isfinite(p)))
            handle.visible = shown
            if shown:
                handle.position = p


def trocar_ring(record: SceneRecord) -> FloatArray:
    """The trocar port's rim: a circle of its radius about the trocar, normal to the insertion
    axis, (RING_POINTS + 1, 3) closed."""
    a = record.axis
    u = np.cross(a, [0.0, 0.0, 1.0] if abs(a[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    t = np.linspace(0.0, 2 * np.pi, RING_POINTS + 1)
    ring = np.cos(t)[:, None] * u + np.sin(t)[:, None] * v
    return np.asarray(record.trocar + record.trocar_radius * ring)
