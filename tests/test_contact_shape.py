"""Clearance and slip velocity are read at the body's lowest point (models/kinematics.py).

For the hoop's circle that point is at depth a, and the rule is the old one (y - a and
xdot - a thetadot). For a faceted contact shape (MuJoCo's ring of capsules, PyBullet's hull)
it is the lowest vertex plus the rounding. A rigid polygon rolling over its vertices without
slipping, built here from rigid-body kinematics about its pivot (not from the rule under
test), has zero slip velocity and zero clearance; the circle's rule reads millimetres per
second of slip on it, and the detectors call a slip within 0.1 s.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hoopbench.engines.judging.detectors import detect_events
from hoopbench.models import kinematics
from hoopbench.models.kinematics import Polygon
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

SCENE = Scene.from_chi(0.3, lam=0.6, eps=0.05, mus=0.5, muk=0.5, a=0.7, M=2.5, theta0=0.4, g=9.81)


def world(u, w, theta):
    """World offset from the hoop centre of the body point (u, w) at angle theta."""
    return u * np.cos(theta) + w * np.sin(theta), w * np.cos(theta) - u * np.sin(theta)


def test_depth_of_a_regular_polygon():
    n, radius, rounding = 12, 0.69, 0.01
    # A vertex straight down at theta = 0: body angle -pi/2 from +u.
    shape = Polygon.regular(n, radius, -math.pi / 2, rounding=rounding)
    assert kinematics.contact_depth(SCENE, 0.0, shape) == pytest.approx(radius + rounding)
    facet = math.pi / n  # half a side further on, a side lies flat
    expected = radius * math.cos(math.pi / n) + rounding
    assert kinematics.contact_depth(SCENE, facet, shape) == pytest.approx(expected)
    assert kinematics.contact_depth(SCENE, [0.0, 2 * math.pi / n], shape) == pytest.approx(
        [radius + rounding] * 2
    )
    np.testing.assert_array_equal(kinematics.contact_depth(SCENE, [0.1, 0.2]), [SCENE.a] * 2)


def test_offset_is_the_rate_of_the_depth():
    shape = Polygon.regular(7, 0.65, 0.3, rounding=0.02)
    theta = np.linspace(0.05, 6.2, 200)
    h = 1e-7
    rate = (
        kinematics.contact_depth(SCENE, theta + h, shape)
        - kinematics.contact_depth(SCENE, theta - h, shape)
    ) / (2 * h)
    offset = kinematics.contact_offset(SCENE, theta, shape)
    smooth = np.abs(rate - offset) < 1e-5  # away from the vertex changes
    assert smooth.mean() > 0.97
    np.testing.assert_array_equal(kinematics.contact_offset(SCENE, theta), 0.0)


def rolling_polygon(shape: Polygon, theta: np.ndarray, thetadot: np.ndarray) -> dict:
    """Hoop-centre states of a sharp polygon rolling without slipping: rotation about the
    lowest vertex, the pivot, which stays put on the floor until the next vertex lands."""
    u, w = np.asarray(shape.vertices).T
    x = np.empty_like(theta)
    y = np.empty_like(theta)
    xdot = np.empty_like(theta)
    ydot = np.empty_like(theta)
    pivot_x, current = 0.0, None
    for k, (th, thd) in enumerate(zip(theta, thetadot, strict=True)):
        dx, dy = world(u, w, th)
        lowest = int(np.argmin(dy))
        if current is not None and lowest != current:
            # The next vertex lands where the body puts it: the old pivot's floor point
            # plus the side between them.
            pivot_x += dx[lowest] - dx[current]
        current = lowest
        # The centre, seen from the pivot P: C - P = -(offset of the vertex).
        cx, cy = -dx[lowest], -dy[lowest]
        x[k], y[k] = pivot_x + cx, cy
        # Clockwise rotation about P at thetadot: v = thetadot * ((C - P)_y, -(C - P)_x).
        xdot[k], ydot[k] = thd * cy, -thd * cx
    return dict(x=x, y=y, xdot=xdot, ydot=ydot)


@pytest.mark.parametrize("segments", [8, 32])
def test_a_polygon_rolling_without_slip_reads_no_slip(segments):
    scene = SCENE.with_(theta0=0.0, thetadot0=1.0)
    shape = Polygon.regular(segments, scene.a, -math.pi / 2)
    t = np.arange(0.0, 1.0 + 1e-12, 1e-4)
    thetadot = 1.0 + 2.0 * t  # any smooth spin-up
    theta = t + t**2
    c = rolling_polygon(shape, theta, thetadot)
    com = kinematics.com_state(scene, c["x"], c["y"], theta, c["xdot"], c["ydot"], thetadot)
    forces = dict(normal_force=np.full_like(t, 9.8), friction_force=np.zeros_like(t))
    polygon = Trajectory.from_state(scene, t=t, **com, **forces, shape=shape)
    circle = Trajectory.from_state(scene, t=t, **com, **forces)

    assert np.max(np.abs(polygon.slip_velocity)) < 1e-12
    assert np.max(np.abs(polygon.clearance)) < 1e-12
    events = detect_events(polygon)
    assert events.t_slip is None and events.t_lift is None

    # The circle's rule reads the centre's ride as slip: (y - a) thetadot.
    ride = scene.a * (1 - math.cos(math.pi / segments))
    worst = np.max(np.abs(circle.slip_velocity))
    assert worst == pytest.approx(ride * thetadot.max(), rel=0.05)
    assert worst > 1e-3
    assert detect_events(circle).t_slip < 0.1


@pytest.mark.parametrize("xdot0", [None, 0.5])
def test_rolling_start_puts_the_lowest_point_on_the_floor_moving_as_the_rim(xdot0):
    scene = SCENE.with_(xdot0=xdot0)
    shape = Polygon.regular(9, 0.68, 0.1, rounding=0.02)
    _x, y, theta, xdot, ydot, thetadot = kinematics.rolling_start(scene, shape)
    assert theta == scene.theta0 and thetadot == scene.thetadot0
    u, w = np.asarray(shape.vertices).T
    dx, dy = world(u, w, theta)
    k = int(np.argmin(dy))
    # The lowest point: the lowest vertex's rounding circle, straight below its centre.
    assert y + dy[k] - shape.rounding == pytest.approx(0.0, abs=1e-15)
    # Its material velocity: v_C + thetadot * ((P - C)_y, -(P - C)_x).
    pc = (dx[k], dy[k] - shape.rounding)
    vx, vy = xdot + thetadot * pc[1], ydot - thetadot * pc[0]
    rim = scene.centre_velocity0 - scene.a * scene.thetadot0  # the circle's slip
    assert vx == pytest.approx(rim, abs=1e-14)
    assert vy == pytest.approx(0.0, abs=1e-14)


def test_the_circle_keeps_its_rule():
    """shape None is the hoop's circle: xdot - a thetadot and y - a, bit for bit."""
    rng = np.random.default_rng(3)
    Y, theta, Xdot, thetadot = rng.normal(size=(4, 50))
    r, a = SCENE.com_offset, SCENE.a
    slip = kinematics.slip_velocity(SCENE, Xdot, theta, thetadot)
    np.testing.assert_array_equal(slip, Xdot - r * np.cos(theta) * thetadot - a * thetadot)
    np.testing.assert_array_equal(kinematics.clearance(SCENE, Y, theta), Y - r * np.cos(theta) - a)
    assert kinematics.rolling_start(SCENE) == pytest.approx(
        (0.0, a, SCENE.theta0, SCENE.centre_velocity0, 0.0, SCENE.thetadot0), abs=1e-15
    )


@pytest.mark.parametrize(
    ("vertices", "rounding", "message"),
    [
        (((0.0, 1.0), (1.0, 0.0)), 0.0, "at least 3 vertices"),
        (((0.0, 1.0), (1.0, 0.0), (0.0, math.nan)), 0.0, "finite"),
        (((0.0, 1.0), (1.0, 0.0), (0.0, -1.0)), -0.1, "rounding must be >= 0"),
    ],
)
def test_bad_polygons_are_refused(vertices, rounding, message):
    with pytest.raises(ValueError, match=message):
        Polygon(vertices, rounding)
