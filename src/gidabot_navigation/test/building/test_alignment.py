"""Aligning blueprints to maps and floors to each other from clicked point pairs (the building editor's fit)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gidabot_navigation.building.alignment import fit_blueprint, fit_floors
from gidabot_navigation.building.geometry import BlueprintTransform
from gidabot_navigation.errors import AlignmentError

FACULTY = BlueprintTransform(16.0, 24.0, 408.0)          # maps/faculty: every floor
CORNERS = [(0.0, 0.0), (72.0, 0.0), (72.0, 24.0), (0.0, 24.0), (35.5, 12.6), (4.4, 12.0)]


def pairs_for(t: BlueprintTransform, points, noise_px: float = 0.0, seed: int = 1):
    rng = np.random.default_rng(seed)
    out = []
    for x, y in points:
        u, v = t.to_pixel(x, y)
        du, dv = rng.normal(0.0, noise_px, 2) if noise_px else (0.0, 0.0)
        out.append(((x, y), (u + du, v + dv)))
    return out


def test_two_exact_pairs_recover_the_faculty_transform() -> None:
    fit = fit_blueprint(pairs_for(FACULTY, [(0.0, 0.0), (72.0, 24.0)]))
    t = fit.transform
    assert t.scale == pytest.approx(16.0)
    assert (t.origin_u, t.origin_v) == (pytest.approx(24.0), pytest.approx(408.0))
    assert t.rotation == pytest.approx(0.0, abs=1e-9)
    assert fit.max_px == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("rotation", [0.3, -1.2, math.pi / 2, 3.0])
def test_rotated_blueprints_are_fitted(rotation: float) -> None:
    truth = BlueprintTransform(11.5, 640.0, 300.0, rotation)
    fit = fit_blueprint(pairs_for(truth, CORNERS))
    assert fit.transform.scale == pytest.approx(11.5)
    assert math.remainder(fit.transform.rotation - rotation, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert fit.transform.to_pixel(10.0, 5.0) == pytest.approx(truth.to_pixel(10.0, 5.0))
    assert fit.rms_px < 1e-6


def test_noisy_clicks_give_the_transform_within_a_percent_and_the_residual_in_pixels() -> None:
    fit = fit_blueprint(pairs_for(FACULTY, CORNERS, noise_px=2.0, seed=7))
    assert fit.transform.scale == pytest.approx(16.0, rel=0.01)
    assert abs(math.degrees(fit.transform.rotation)) < 0.5
    assert 0.5 < fit.rms_px < 4.0 and fit.max_px >= fit.rms_px
    assert len(fit.residuals_px) == len(CORNERS)


def test_one_click_off_by_many_pixels_shows_in_its_residual() -> None:
    pairs = pairs_for(FACULTY, CORNERS)
    (xy, (u, v)) = pairs[2]
    pairs[2] = (xy, (u + 40.0, v))
    fit = fit_blueprint(pairs)
    assert int(np.argmax(fit.residuals_px)) == 2 and fit.max_px > 20


def test_a_mirrored_blueprint_is_refused_with_the_reason() -> None:
    mirrored = [((x, y), (1200.0 - u, v)) for (x, y), (u, v) in pairs_for(FACULTY, CORNERS)]
    with pytest.raises(AlignmentError, match="mirror image: the blueprint is mirrored"):
        fit_blueprint(mirrored)


@pytest.mark.parametrize("pairs, reason", [
    ([], "0 point pair"), ([((1.0, 2.0), (3.0, 4.0))], "1 point pair"),
    ([((1.0, 2.0), (3.0, 4.0)), ((1.0, 2.0), (50.0, 4.0))], "map points are all at one spot"),
    ([((1.0, 2.0), (3.0, 4.0)), ((9.0, 2.0), (3.0, 4.0))], "blueprint points are all at one spot"),
    ([((1.0, 2.0), (3.0, 4.0)), ((9.0, float("nan")), (3.0, 4.0))], "not a finite number"),
])
def test_too_few_or_degenerate_pairs_are_refused(pairs, reason: str) -> None:
    with pytest.raises(AlignmentError, match=reason):
        fit_blueprint(pairs)


def test_floors_fit_is_rigid_and_reports_the_scale() -> None:
    yaw, dx, dy = 0.4, 3.0, -2.0
    c, s = math.cos(yaw), math.sin(yaw)
    pts = [(0.0, 0.0), (10.0, 0.0), (10.0, 5.0), (2.0, 7.0)]
    pairs = [((x, y), (dx + c * x - s * y, dy + s * x + c * y)) for x, y in pts]
    fit = fit_floors(pairs)
    assert (fit.pose.x, fit.pose.y, fit.pose.yaw) == (pytest.approx(dx), pytest.approx(dy), pytest.approx(yaw))
    assert fit.scale == pytest.approx(1.0) and fit.max_m < 1e-9
    doubled = [((x, y), (2 * a, 2 * b)) for (x, y), (a, b) in pairs]
    assert fit_floors(doubled).scale == pytest.approx(2.0)
