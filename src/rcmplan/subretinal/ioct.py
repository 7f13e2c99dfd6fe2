"""Simulated intraoperative OCT: acquisition timing and a synthetic B-scan around the needle.

The OCT is fixed in the room. Volumes are acquired at `volume_rate_hz`; each is reduced to the
B-scan through the needle, treated as taken at one instant t_acq, and its segmentation reaches
the controller at t_acq + `latency_s`.

B-scan frame: x lateral [m] (0 at the scan centre, the needle in the scan plane), z depth [m]
along the retina's outward normal (0 at the undisplaced ILM at x = 0). Row k covers depth
[z_top + k dz, z_top + (k + 1) dz], z_top = -`top_m`; column j is the A-line at
x_j = (j - (n - 1) / 2) dx. Each pixel samples the reflectivity at its centre, except where a
step (a layer or needle surface) crosses it: there it takes the two sides' mean weighted by the
parts of the row they cover (a box-filtered edge, so edges fall between rows). Each pixel then
carries multiplicative speckle (intensity ~ Gamma(L, 1/L), L = `speckle_looks`; L = 1 is
fully developed speckle, a Rayleigh amplitude) plus an exponential noise floor; the image is
returned in dB, 10 log10(intensity).

What the image shows (reflectivities relative to the ILM, assumed; docs/subretinal.md):
vitreous dark; a bright ILM/nerve-fibre edge decaying into the retina, darker outer retina; the
RPE as a 15.5 um band (PMC6042244: 13.5-17.5 um) at the RPE surface; the choroid decaying
below it, then the sclera; the needle (a flat-ended cannula in the scan plane) as a bright top
surface with a shadow under it. Layer positions come from `BScanScene`, the truth the
segmentation is scored on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError

ILM_EDGE, ILM_DECAY_M = 0.7, 15e-6  # bright ILM/NFL edge over a 15 um decay
INNER_RETINA, OUTER_RETINA = 0.35, 0.05  # falls linearly from the ILM to the RPE
RPE, RPE_BAND_M = 0.8, 15.5e-6
CHOROID, CHOROID_DECAY_M = 0.35, 150e-6
SCLERA = 0.2
NEEDLE, NEEDLE_BAND_M = 8.0, 8e-6  # metal surface; nothing below it but the noise floor
NEEDLE_LENGTH_M = 0.02  # far beyond the top of any window


@dataclass(frozen=True)
class IoctModel:
    """Acquisition and image parameters.

    Attributes:
        volume_rate_hz: Volumes per second (9 Hz: B5-scans of the TUM set-up).
        latency_s: Acquisition to delivery of the segmentation [s] (150 ms).
        axial_pixel_m: Axial pixel [m] (3.379 mm / 1024 px = 3.3 um).
        depth_px: Rows of a B-scan.
        lateral_pixel_m: Lateral A-line spacing [m] (12 um: 4 mm over 340 A-scans).
        lateral_px: A-lines of a B-scan.
        top_m: Height [m] of the first row above the undisplaced ILM.
        speckle_looks: Shape L of the Gamma speckle (1 = fully developed).
        noise_floor: Mean noise intensity relative to the ILM edge.
    """

    volume_rate_hz: float = 9.0
    latency_s: float = 0.15
    axial_pixel_m: float = 3.3e-6
    depth_px: int = 256
    lateral_pixel_m: float = 12e-6
    lateral_px: int = 96
    top_m: float = 300e-6
    speckle_looks: float = 1.0
    noise_floor: float = 0.02

    def __post_init__(self) -> None:
        scalar("volume_rate_hz", self.volume_rate_hz, 0.1, 200.0)
        scalar("latency_s", self.latency_s, 0.0, 2.0)
        scalar("axial_pixel_m", self.axial_pixel_m, 0.5e-6, 50e-6)
        scalar("lateral_pixel_m", self.lateral_pixel_m, 0.5e-6, 200e-6)
        for name, low, high in (("depth_px", 32, 4096), ("lateral_px", 8, 2048)):
            value = getattr(self, name)
            if not isinstance(value, int) or not low <= value <= high:
                raise InvalidInputError(name, value, f"an integer in [{low}, {high}]")
        scalar("top_m", self.top_m, 0.0, self.depth_px * self.axial_pixel_m)
        scalar("speckle_looks", self.speckle_looks, 0.1, 1e4)
        scalar("noise_floor", self.noise_floor, 1e-6, 1.0)

    @property
    def period_s(self) -> float:
        """Time between volumes [s]."""
        return 1.0 / self.volume_rate_hz

    def depth_axis_m(self) -> FloatArray:
        """Depth z [m] of each row's centre (depth_px,)."""
        rows = np.arange(self.depth_px, dtype=np.float64)
        return np.asarray(-self.top_m + (rows + 0.5) * self.axial_pixel_m, dtype=np.float64)

    def lateral_axis_m(self) -> FloatArray:
        """Lateral x [m] of each A-line (lateral_px,)."""
        cols = np.arange(self.lateral_px, dtype=np.float64) - 0.5 * (self.lateral_px - 1)
        return np.asarray(cols * self.lateral_pixel_m, dtype=np.float64)

    def acquisition_times(self, duration_s: float, start_s: float = 0.0) -> FloatArray:
        """Acquisition instants [s] in [start_s, duration_s], one volume period apart."""
        n = math.floor((duration_s - start_s) * self.volume_rate_hz + 1e-9) + 1
        return np.asarray(start_s + np.arange(max(n, 0)) * self.period_s, dtype=np.float64)


@dataclass(frozen=True)
class BScanScene:
    """The truth one acquisition sees, in the B-scan frame (module docstring).

    Attributes:
        ilm_offset_m: ILM displacement along the normal seen by the OCT [m] (d + T.n).
        lateral_shift_m: Lateral eye translation along x [m] (T.x).
        curvature_radius_m: ILM radius [m] (the layers' curvature across the scan).
        thickness_m: ILM-to-RPE thickness [m].
        choroid_m: Choroid thickness [m]; the sclera lies below it.
        tent_m: Tenting displacement of the ILM [m] (a Gaussian dent centred at tent_x_m).
        tent_x_m: Lateral centre of the dent [m].
        tent_width_m: Standard deviation of the dent [m].
        rpe_coupling: Fraction of the dent the RPE follows.
        tip_m: Needle tip (x, z) on its axis [m], or None for no needle in the scan.
        needle_tilt_rad: Needle angle from the depth axis [rad]; positive: the shaft comes from
            the upper left and points down to the right. |tilt| in [0.1, 1.4] rad.
        needle_diameter_m: Outer diameter of the cannula [m].
    """

    ilm_offset_m: float = 0.0
    lateral_shift_m: float = 0.0
    curvature_radius_m: float = 11e-3
    thickness_m: float = 250e-6
    choroid_m: float = 200e-6
    tent_m: float = 0.0
    tent_x_m: float = 0.0
    tent_width_m: float = 150e-6
    rpe_coupling: float = 0.2
    tip_m: tuple[float, float] | None = None
    needle_tilt_rad: float = 0.5
    needle_diameter_m: float = 100e-6

    def __post_init__(self) -> None:
        scalar("ilm_offset_m", self.ilm_offset_m, -1e-3, 1e-3)
        scalar("curvature_radius_m", self.curvature_radius_m, 1e-3, 0.05)
        scalar("thickness_m", self.thickness_m, 10e-6, 1e-3)
        scalar("choroid_m", self.choroid_m, RPE_BAND_M, 2e-3)
        scalar("tent_m", self.tent_m, 0.0, 1e-3)
        scalar("needle_diameter_m", self.needle_diameter_m, 10e-6, 1e-3)
        if abs(self.needle_tilt_rad) < 0.1 or abs(self.needle_tilt_rad) > 1.4:
            raise InvalidInputError("needle_tilt_rad", self.needle_tilt_rad, "|tilt| in [0.1, 1.4]")

    def _sag(self, x: FloatArray, radius: float) -> FloatArray:
        u = np.minimum(np.abs(x - self.lateral_shift_m), 0.99 * radius)
        return radius - np.sqrt(radius * radius - u * u)

    def _dent(self, x: FloatArray) -> FloatArray:
        if self.tent_m == 0.0:
            return np.zeros_like(x)
        return self.tent_m * np.exp(-0.5 * ((x - self.tent_x_m) / self.tent_width_m) ** 2)

    def ilm_depth_m(self, x: object) -> FloatArray:
        """True ILM depth z [m] at lateral positions x [m]."""
        xx = np.asarray(x, dtype=np.float64)
        return self.ilm_offset_m - self._sag(xx, self.curvature_radius_m) + self._dent(xx)

    def rpe_depth_m(self, x: object) -> FloatArray:
        """True RPE-surface depth z [m] at lateral positions x [m]."""
        xx = np.asarray(x, dtype=np.float64)
        sag = self._sag(xx, self.curvature_radius_m + self.thickness_m)
        return self.ilm_offset_m + self.thickness_m - sag + self.rpe_coupling * self._dent(xx)

    def needle_top_m(self, x: FloatArray) -> FloatArray:
        """Depth z [m] of the needle's first surface along the A-lines at x [m] (inf where an
        A-line misses the needle): the flat-ended shaft |across| <= r, 0 <= back <= length."""
        if self.tip_m is None:
            return np.full(np.shape(x), np.inf)
        s, c = math.sin(self.needle_tilt_rad), math.cos(self.needle_tilt_rad)
        dx = np.asarray(x, dtype=np.float64) - self.tip_m[0]
        r = math.copysign(0.5 * self.needle_diameter_m, s)
        low = np.maximum((dx * c - r) / s, (-NEEDLE_LENGTH_M - dx * s) / c)
        high = np.minimum((dx * c + r) / s, -dx * s / c)
        return np.where(low <= high, self.tip_m[1] + low, np.inf)


@njit(cache=True)
def reflectivity_at(z: float, ilm: float, rpe: float, choroid: float, top: float) -> float:
    """Noise-free reflectivity at depth z [m] of an A-line whose ILM, RPE surface and needle
    surface (inf: none) lie at depths ilm, rpe, top [m], the choroid `choroid` [m] thick: the
    tissue, and over it the needle's surface and its shadow."""
    if z >= top:
        return NEEDLE if z < top + NEEDLE_BAND_M else 0.0  # the surface, then the shadow
    u, v = z - ilm, z - rpe
    if v >= choroid:
        return SCLERA
    if v >= RPE_BAND_M:
        return CHOROID * math.exp(-(v - RPE_BAND_M) / CHOROID_DECAY_M)
    if v >= 0.0:
        return RPE
    if u >= 0.0:  # the decay starts at the ILM
        frac = min(max(u / max(rpe - ilm, 1e-9), 0.0), 1.0)
        return (
            ILM_EDGE * math.exp(-u / ILM_DECAY_M)
            + INNER_RETINA
            + frac * (OUTER_RETINA - INNER_RETINA)
        )
    return 0.0


def _depths(scene: BScanScene, x: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The ILM, RPE-surface and needle-surface depths [m] at A-lines x (contiguous arrays)."""
    return (np.ascontiguousarray(scene.ilm_depth_m(x)), np.ascontiguousarray(scene.rpe_depth_m(x)),
            np.ascontiguousarray(scene.needle_top_m(x)))  # fmt: skip


@njit(cache=True)
def _reflectivities(
    z: FloatArray, ilm: FloatArray, rpe: FloatArray, top: FloatArray, choroid: float
) -> FloatArray:
    out = np.empty(z.size)
    for k in range(z.size):
        out[k] = reflectivity_at(z[k], ilm[k], rpe[k], choroid, top[k])
    return out


def reflectivity(scene: BScanScene, x: FloatArray, z: FloatArray) -> FloatArray:
    """Noise-free reflectivity at A-lines x and depths z [m] (broadcast together):
    `reflectivity_at` at each point."""
    xb, zb = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(z, dtype=np.float64))
    xf, zf = np.ascontiguousarray(xb).ravel(), np.ascontiguousarray(zb).ravel()
    ilm, rpe, top = _depths(scene, xf)
    out = _reflectivities(zf, ilm, rpe, top, scene.choroid_m)
    return out.reshape(xb.shape)


@njit(cache=True)
def _clean_image(
    z0: float, dz: float, rows: int, ilm: FloatArray, rpe: FloatArray, top: FloatArray,
    choroid: float,
) -> FloatArray:  # fmt: skip
    """The noise-free B-scan (rows, A-lines) of `clean_bscan` from the depths per A-line."""
    cols = ilm.size
    image = np.empty((rows, cols))
    eps = 1e-3 * dz
    for j in range(cols):
        a, b, c = ilm[j], rpe[j], top[j]
        for i in range(rows):
            image[i, j] = reflectivity_at(z0 + (i + 0.5) * dz, a, b, choroid, c)
        # the steps: ILM, RPE top and bottom, sclera, needle surface top and bottom
        for e in (a, b, b + RPE_BAND_M, b + choroid, c, c + NEEDLE_BAND_M):
            pos = (e - z0) / dz
            if math.isfinite(pos) and 0.0 <= pos < rows:
                i = math.floor(pos)
                above = pos - i  # the fraction of the row above the edge
                image[i, j] = above * reflectivity_at(e - eps, a, b, choroid, c) + (
                    1.0 - above
                ) * reflectivity_at(e + eps, a, b, choroid, c)
    return image


def clean_bscan(model: IoctModel, scene: BScanScene) -> FloatArray:
    """Noise-free B-scan (depth_px, lateral_px): the reflectivity at each row's centre, and in
    each row a step crosses the mean over the row of the two sides (a box-filtered edge). The
    edges are written from the ILM down, then the needle's (a later one over an earlier one in
    the same pixel)."""
    ilm, rpe, top = _depths(scene, model.lateral_axis_m())
    return _clean_image(-model.top_m, model.axial_pixel_m, model.depth_px, ilm, rpe, top,
                        scene.choroid_m)  # fmt: skip


def render_bscan(model: IoctModel, scene: BScanScene, rng: np.random.Generator) -> FloatArray:
    """A synthetic B-scan (depth_px, lateral_px) in dB of `scene` with speckle from `rng`."""
    clean = clean_bscan(model, scene)
    looks = model.speckle_looks
    speckle = rng.standard_gamma(looks, size=clean.shape)
    speckle *= 1.0 / looks  # Gamma(L, 1 / L), as rng.gamma(L, 1 / L) draws it
    noise = rng.standard_exponential(size=clean.shape)
    noise *= model.noise_floor
    image: FloatArray = 10.0 * np.log10(clean * speckle + noise)
    return image
