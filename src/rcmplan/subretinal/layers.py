"""The retina as layers on the posterior eye wall: ILM and RPE surfaces, choroid and sclera.

All surfaces are spheres concentric with the eye. Points are in the eye frame (origin at the
eye centre, `rcmplan.scene.eye.eye_frame`), in [m]. The local normal n of the wall at a point is
the outward radial unit vector: depth below the ILM grows along n, away from the vitreous.
A physiological wall displacement d [m] (`motion.py`) moves every surface along n by d: positive
d moves the wall away from the eye centre (deeper, away from the needle).

Layers, from the vitreous outwards:
    ILM    radius R_ilm (the eye's retina radius, `Eye.retina_radius`)
    RPE    radius R_ilm + thickness: the inner (vitreal) face of the RPE, the surface the
           needle must not pass; the subretinal space lies just inside it
    choroid from the RPE to R_ilm + thickness + choroid thickness
    sclera from there to the eye's outer radius

The injection target is a depth, as a fraction of the thickness between ILM (0) and RPE (1),
with a band of +- `band_fraction` of the thickness around it. Sources of every default:
docs/subretinal.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.needle import angle_between
from rcmplan.scene.eye import Eye

# Retinal thickness published for human maculae (fovea 257 +- 19 um, i.e. from 238 um, to
# pericentral 340 um; PMC6042244) and porcine retinae ("about 250 um", Arikan et al.).
THICKNESS_RANGE_M = (238e-6, 340e-6)


@dataclass(frozen=True)
class RetinaLayers:
    """The retina's layers on a spherical posterior wall.

    Attributes:
        ilm_radius_m: Radius of the ILM sphere [m] (the eye's retina radius, 11 mm by default).
        thickness_m: ILM-to-RPE thickness [m], within `THICKNESS_RANGE_M`.
        choroid_m: Choroid thickness [m] behind the RPE (assumed 200 um).
        eye_radius_m: Outer (scleral) radius [m]; the sclera fills what the choroid leaves.
        target_fraction: Target depth as a fraction of the thickness, ILM 0 to RPE 1.
        band_fraction: Half-width of the target band as a fraction of the thickness.
    """

    ilm_radius_m: float = 11e-3
    thickness_m: float = 250e-6
    choroid_m: float = 200e-6
    eye_radius_m: float = 12e-3
    target_fraction: float = 0.5
    band_fraction: float = 0.1

    def __post_init__(self) -> None:
        scalar("ilm_radius_m", self.ilm_radius_m, 0.0, 0.05, low_open=True)
        scalar("thickness_m", self.thickness_m, *THICKNESS_RANGE_M)
        scalar("choroid_m", self.choroid_m, 0.0, 1e-3)
        low = self.ilm_radius_m + self.thickness_m + self.choroid_m
        scalar("eye_radius_m", self.eye_radius_m, low, 0.05, low_open=True)
        scalar("target_fraction", self.target_fraction, 0.0, 1.0, low_open=True, high_open=True)
        half = min(self.target_fraction, 1.0 - self.target_fraction)
        scalar("band_fraction", self.band_fraction, 0.0, half)

    @classmethod
    def from_eye(cls, eye: Eye, **kwargs: float) -> RetinaLayers:
        """Layers on an eye: ILM at the eye's retina radius, sclera out to its outer radius."""
        return cls(ilm_radius_m=eye.retina_radius, eye_radius_m=eye.radius, **kwargs)

    @property
    def rpe_radius_m(self) -> float:
        """Radius of the RPE's inner face [m]."""
        return self.ilm_radius_m + self.thickness_m

    @property
    def sclera_radius_m(self) -> float:
        """Radius of the sclera's inner face (the choroid's outer face) [m]."""
        return self.rpe_radius_m + self.choroid_m

    @property
    def sclera_m(self) -> float:
        """Sclera thickness [m]."""
        return self.eye_radius_m - self.sclera_radius_m

    @property
    def target_depth_m(self) -> float:
        """Target depth below the ILM [m]."""
        return self.target_fraction * self.thickness_m

    @property
    def band_m(self) -> tuple[float, float]:
        """Target band (shallowest, deepest) as depths below the ILM [m]."""
        half = self.band_fraction * self.thickness_m
        return self.target_depth_m - half, self.target_depth_m + half


class RpeExcess(NamedTuple):
    """Whether points lie past the RPE's inner face, and by how much.

    Attributes:
        past: True where a point lies deeper than the RPE surface.
        by_m: Depth beyond the RPE surface [m]: positive past it, negative short of it.
    """

    past: np.ndarray | bool
    by_m: FloatArray | float


def _points(name: str, p: object) -> FloatArray:
    """p as a finite (3,) or (N, 3) float array, or raise."""
    arr = np.asarray(p, dtype=np.float64)
    if arr.ndim not in (1, 2) or arr.shape[-1] != 3:
        raise InvalidInputError(name, p, f"a point (3,) or points (N, 3), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise InvalidInputError(name, p, "finite numbers (no NaN or inf)")
    return arr


def _scalar_or_array(x: FloatArray) -> FloatArray | float:
    return float(x) if x.ndim == 0 else x


def depth_below_ilm(
    layers: RetinaLayers, points: object, displacement_m: float = 0.0
) -> FloatArray | float:
    """Signed depth [m] of points below the (displaced) ILM along the local normal.

    Args:
        points: Point (3,) or points (N, 3) in the eye frame [m].
        displacement_m: Wall displacement along the outward normal [m].

    Returns:
        |p| - (R_ilm + d): positive inside the retina, negative in the vitreous; a float for
        one point, an (N,) array for N.
    """
    p = _points("points", points)
    d = scalar("displacement_m", displacement_m, -1e-3, 1e-3)
    return _scalar_or_array(np.linalg.norm(p, axis=-1) - (layers.ilm_radius_m + d))


def past_rpe(layers: RetinaLayers, points: object, displacement_m: float = 0.0) -> RpeExcess:
    """Whether points lie past the (displaced) RPE surface, and the depth beyond it [m]."""
    by = np.asarray(depth_below_ilm(layers, points, displacement_m)) - layers.thickness_m
    past = by > 0.0
    return RpeExcess(bool(past) if by.ndim == 0 else past, _scalar_or_array(by))


def in_target_band(layers: RetinaLayers, depth_m: object) -> np.ndarray | bool:
    """Whether depths below the ILM [m] lie inside the target band."""
    d = np.asarray(depth_m, dtype=np.float64)
    if not np.isfinite(d).all():
        raise InvalidInputError("depth_m", depth_m, "finite depths [m]")
    lo, hi = layers.band_m
    inside = (d >= lo) & (d <= hi)
    return bool(inside) if inside.ndim == 0 else inside


def unit_direction(direction: object) -> FloatArray:
    """A retina location given as a direction from the eye centre, normalised, or raise."""
    v = vector("direction", direction, 3)
    norm = float(np.linalg.norm(v))
    if norm < 1e-12:
        raise InvalidInputError("direction", v.tolist(), "a non-zero direction (3,)")
    return v / norm


def target_point(
    layers: RetinaLayers, direction: object, displacement_m: float = 0.0
) -> FloatArray:
    """The injection target (3,) [m] at a retina location: on the ray from the eye centre along
    `direction`, `target_depth_m` below the ILM displaced by `displacement_m` along the normal."""
    d = scalar("displacement_m", displacement_m, -1e-3, 1e-3)
    radius = layers.ilm_radius_m + d + layers.target_depth_m
    return radius * unit_direction(direction)


def incidence_rad(layers: RetinaLayers, direction: object, trocar: object) -> float:
    """Angle [rad] between the local normal at a retina location and a straight needle that
    reaches the location's ILM point from the trocar (3,) [m, eye frame]; 0 at normal incidence.
    The B-scan renderer (`ioct.py`) takes this as the needle's tilt from the depth axis."""
    n = unit_direction(direction)
    c = vector("trocar", trocar, 3)
    ray = layers.ilm_radius_m * n - c
    length = float(np.linalg.norm(ray))
    if length < 1e-9:
        raise InvalidInputError("trocar", c.tolist(), "a point off the target's ILM point")
    return angle_between(ray, n)
