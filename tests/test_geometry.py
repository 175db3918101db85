import math
from decimal import Decimal

import numpy as np
import pytest
from conftest import MODELS

from deltacal import GeometryError, InputError, Tolerances
from deltacal.geometry import error_names
from deltacal.io import exact_degrees, load_geometry, load_nominal, radians_from_text, save_geometry


def test_bai2015_file_matches_table1(bai):
    assert (bai.base_radius, bai.plate_radius, bai.arm_length, bai.rod_length, bai.rod_spacing) == (
        200.0, 51.0, 375.0, 950.0, 100.0)
    ws = bai.workspace
    assert (ws.radius, ws.height, ws.top_z) == (500.0, 250.0, -728.0)
    np.testing.assert_allclose(np.degrees(bai.limb_azimuth), [-90.0, 30.0, 150.0])


def test_nominal_geometry_follows_conventions(bai):
    g = bai.geometry()
    r, t = bai.radial, bai.tangent
    np.testing.assert_allclose(g.axis_point, bai.base_radius * r)
    np.testing.assert_allclose(g.axis_direction, t)
    # q = 0: arm horizontal and outward; q > 0 lowers the arm tip
    balls0 = g.arm_balls_in_base(np.zeros((1, 3)))[0]
    elbow0 = balls0.mean(axis=1)
    np.testing.assert_allclose(elbow0, (bai.base_radius + bai.arm_length) * r, atol=1e-12)
    np.testing.assert_allclose(balls0[:, 0] - balls0[:, 1], bai.rod_spacing * t, atol=1e-12)
    elbow = g.arm_balls_in_base(np.full((1, 3), 0.3))[0].mean(axis=1)
    u = math.cos(0.3) * r - math.sin(0.3) * np.array([0, 0, 1.0])
    np.testing.assert_allclose(elbow, bai.base_radius * r + bai.arm_length * u, atol=1e-12)
    assert g.is_perfect()


def test_geometry_toml_round_trip_is_exact(bai, tmp_path):
    rng = np.random.default_rng(7)
    g = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    path = tmp_path / "g.toml"
    save_geometry(g, path)
    back = load_geometry(path)
    assert back.allclose(g, atol=0.0)
    assert back.name == g.name and set(back.points) == set(g.points)
    path2 = tmp_path / "g2.toml"
    save_geometry(back, path2)
    assert path.read_text() == path2.read_text()


def test_exact_degrees_round_trips_every_angle():
    rng = np.random.default_rng(3)
    for a in rng.normal(0.0, 1.0, 2000):
        text = exact_degrees(float(a))
        assert radians_from_text(Decimal(text)) == a
        assert abs(float(text) - math.degrees(a)) < 1e-12


def test_perturbation_is_seeded_and_sized(bai):
    g = bai.geometry()
    a = g.perturbed(Tolerances(), np.random.default_rng(1))
    b = g.perturbed(Tolerances(), np.random.default_rng(1))
    c = g.perturbed(Tolerances(), np.random.default_rng(2))
    assert a.allclose(b) and not a.allclose(c)
    tol = Tolerances(ball_centre=0.0, rod_length=0.1, axis_position=0.0, axis_direction=0.0,
                     encoder_offset=0.0)
    d = g.perturbed(tol, np.random.default_rng(4))
    np.testing.assert_array_equal(d.plate_ball, g.plate_ball)
    assert 0.01 < np.std(d.rod_length - g.rod_length) < 0.3
    assert not d.is_perfect()


def test_with_errors_by_name_and_deviation_round_trip(bai):
    g = bai.geometry()
    errors = {name: 1e-4 * (k + 1) for k, name in enumerate(error_names())}
    h = g.with_errors(errors)
    dev = h.deviation_from(g)
    for name, value in errors.items():
        # axis tilts are finite rotations read back to first order: error ~ tilt^2 (tilts <= 6e-3 rad)
        tol = 5e-5 * abs(value) if "axis_tilt" in name else 1e-12
        assert dev[name] == pytest.approx(value, abs=tol), name
    assert h.rod_length[1, 0] == g.rod_length[1, 0] + errors["limb2.rod1.length"]
    assert h.encoder_offset[2] == pytest.approx(errors["limb3.encoder_offset"])
    with pytest.raises(GeometryError, match="limb4"):
        g.with_errors({"limb4.rod1.length": 1.0})


@pytest.mark.parametrize(
    "old, new, key",
    [
        ("arm_length_mm = 375.0", "arm_length_mm = -375.0", "geometry.arm_length_mm"),
        ("arm_length_mm = 375.0", "arm_length_mm = \"long\"", "geometry.arm_length_mm"),
        ("rod_length_mm = 950.0", "rod_length_mm = 0.0", "geometry.rod_length_mm"),
        ("rod_length_mm = 950.0", "rod_length_mm = 30.0", "geometry.rod_length_mm"),
        ("rod_length_mm = 950.0", "rod_lenght_mm = 950.0", "geometry.rod_lenght_mm"),
        ("limb_azimuth_deg = [-90.0, 30.0, 150.0]", "limb_azimuth_deg = [-90.0, 30.0]",
         "geometry.limb_azimuth_deg"),
        ("limb_azimuth_deg = [-90.0, 30.0, 150.0]", "limb_azimuth_deg = [0.0, 0.0, 150.0]",
         "geometry.limb_azimuth_deg"),
        ("top_z_mm = -728.0", "top_z_mm = 100.0", "workspace.top_z_mm"),
        ("radius_mm = 500.0", "radius_mm = 5000.0", "workspace"),
        ("base_radius_mm = 200.0", "base_radius_mm = nan", "geometry.base_radius_mm"),
    ],
)
def test_bad_robot_file_names_the_key(tmp_path, old, new, key):
    text = (MODELS / "bai2015.toml").read_text()
    assert old in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new))
    with pytest.raises(InputError) as info:
        load_nominal(path)
    assert str(path) in str(info.value)
    assert f"key {key}" in str(info.value)


def test_missing_and_empty_robot_files(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_nominal(tmp_path / "nope.toml")
    (tmp_path / "empty.toml").write_text("")
    with pytest.raises(InputError, match="empty"):
        load_nominal(tmp_path / "empty.toml")
    (tmp_path / "broken.toml").write_text("name = \n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_nominal(tmp_path / "broken.toml")
    text = (MODELS / "bai2015.toml").read_text().replace("arm_length_mm = 375.0", "")
    (tmp_path / "missing.toml").write_text(text)
    with pytest.raises(InputError, match="key geometry.arm_length_mm: missing required key"):
        load_nominal(tmp_path / "missing.toml")
