"""Aligning a blueprint to its floor's map, and one floor's map to another's, from matching points (ROS-free).

A person clicks the same features (a corner, a door, the lift) on both images; the building editor turns the
point pairs into the transform with a least-squares fit (Umeyama, "Least-squares estimation of transformation
parameters between two point patterns", 1991):

- :func:`fit_blueprint`: map metres -> blueprint pixels, a *similarity* (scale, rotation, translation): the
  floor's ``blueprint_transform``. The blueprint's v axis points down: the fit is made in (u, -v), where the
  transform is a rotation and a scale, so a mirror image cannot be fitted: a blueprint that is mirrored against
  its map (three or more pairs that only a reflection matches) is refused, as are fewer than two pairs and
  points all at one spot.
- :func:`fit_floors`: one floor's map metres -> another floor's, a *rigid* motion (both maps are in metres: no
  scale; the similarity's scale is reported, a value far from 1 means a map with a wrong resolution).

Each result carries the residual of every pair (pixels, or metres), their root mean square and maximum: how well
the points agree with one transform (a point clicked off by a few pixels shows there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gidabot_navigation.building.geometry import BlueprintTransform, Pose2D, wrap_angle
from gidabot_navigation.errors import AlignmentError

MIN_SPREAD = 1e-6          # squared spread (m^2 or px^2) below which points are "at one spot"
MIRROR_RATIO = 0.05        # the second singular value must be this share of the first to tell a mirror (not a line)

PointPairs = Sequence[tuple[tuple[float, float], tuple[float, float]]]


@dataclass(frozen=True)
class BlueprintFit:
    transform: BlueprintTransform
    residuals_px: tuple[float, ...]    # per pair: distance from its blueprint point to where its map point lands
    rms_px: float
    max_px: float


@dataclass(frozen=True)
class FloorFit:
    pose: Pose2D                       # the map frame of the fitted floor in the reference floor's map frame
    residuals_m: tuple[float, ...]
    rms_m: float
    max_m: float
    scale: float                       # of the best similarity: about 1 for two maps in metres

    def to_reference(self, x: float, y: float) -> tuple[float, float]:
        """A point of the fitted floor's map in the reference floor's map (m)."""
        c, s = math.cos(self.pose.yaw), math.sin(self.pose.yaw)
        return (self.pose.x + c * x - s * y, self.pose.y + s * x + c * y)


def _pairs(pairs: PointPairs, what: str) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(pairs, (list, tuple)) or len(pairs) < 2:
        count = len(pairs) if isinstance(pairs, (list, tuple)) else 0
        raise AlignmentError(f"{count} point pair(s): click at least 2 matching points on the map and on the "
                             f"{what} (3 or more, spread apart, show how well they agree)")
    try:
        arr = np.array([[a[0], a[1], b[0], b[1]] for a, b in pairs], dtype=np.float64)
    except (TypeError, ValueError, IndexError) as err:
        raise AlignmentError(f"point pairs must be ((x, y), (u, v)) numbers: {err}") from err
    if not np.isfinite(arr).all():
        raise AlignmentError("point pairs hold a value that is not a finite number")
    return arr[:, :2], arr[:, 2:]


def _umeyama(src: np.ndarray, dst: np.ndarray, what: str, with_scale: bool) -> tuple[float, np.ndarray, np.ndarray]:
    """(scale, rotation matrix, translation) minimising sum |dst - (scale R src + t)|^2, R a proper rotation."""
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    sc, dc = src - mu_s, dst - mu_d
    var_s = float((sc ** 2).sum(axis=1).mean())
    if var_s < MIN_SPREAD:
        raise AlignmentError("the map points are all at one spot: click points far apart (opposite corners)")
    if float((dc ** 2).sum(axis=1).mean()) < MIN_SPREAD:
        raise AlignmentError(f"the {what} points are all at one spot: click points far apart (opposite corners)")
    cov = dc.T @ sc / len(src)
    u, d, vt = np.linalg.svd(cov)
    flip = np.linalg.det(u) * np.linalg.det(vt) < 0
    if flip and d[1] > MIRROR_RATIO * d[0]:
        raise AlignmentError(f"the points match only as a mirror image: the {what} is mirrored (flipped) against "
                             "the map; flip the image, or check that each pair is the same feature on both")
    s = np.diag([1.0, -1.0 if flip else 1.0])
    rot = u @ s @ vt
    scale = float(np.trace(np.diag(d) @ s) / var_s) if with_scale else 1.0
    return scale, rot, mu_d - scale * rot @ mu_s


def fit_blueprint(pairs: PointPairs) -> BlueprintFit:
    """The ``blueprint_transform`` mapping each map point (x, y, m) onto its blueprint pixel (u, v), least squares;
    :class:`AlignmentError` as the module docstring says."""
    src, dst = _pairs(pairs, "blueprint")
    flipped = dst * np.array([1.0, -1.0])                  # (u, -v): a right-handed frame like the map's
    scale, rot, t = _umeyama(src, flipped, "blueprint", with_scale=True)
    if scale <= 0:
        raise AlignmentError("the points do not determine a scale: click points far apart")
    rotation = wrap_angle(math.atan2(rot[1, 0], rot[0, 0]))
    transform = BlueprintTransform(scale, float(t[0]), float(-t[1]), 0.0 if abs(rotation) < 1e-12 else rotation)
    residuals = tuple(math.dist(transform.to_pixel(x, y), (u, v)) for (x, y), (u, v) in zip(src, dst, strict=True))
    return BlueprintFit(transform, residuals, _rms(residuals), max(residuals))


def fit_floors(pairs: PointPairs) -> FloorFit:
    """Where one floor's map lies in another's: each pair is (point on this floor's map, the same feature on the
    reference floor's map), metres; a rigid fit (:class:`AlignmentError` as for blueprints)."""
    src, dst = _pairs(pairs, "other floor's map")
    scale, _, _ = _umeyama(src, dst, "other floor's map", with_scale=True)
    _, rot, t = _umeyama(src, dst, "other floor's map", with_scale=False)
    fit = FloorFit(Pose2D(float(t[0]), float(t[1]), wrap_angle(math.atan2(rot[1, 0], rot[0, 0]))), (), 0.0, 0.0, scale)
    residuals = tuple(math.dist(fit.to_reference(x, y), (a, b)) for (x, y), (a, b) in zip(src, dst, strict=True))
    return FloorFit(fit.pose, residuals, _rms(residuals), max(residuals), scale)


def _rms(values: tuple[float, ...]) -> float:
    return math.sqrt(sum(v * v for v in values) / len(values))
