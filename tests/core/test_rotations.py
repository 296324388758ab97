import numpy as np
import pytest

from casadi_sins.core import earth, orientation, rotations

# Table 1 of the paper: every static position and the rotations between them.
TABLE1 = [
    (["NUE", "USE", "SDE", "DNE"], "+Z"),
    (["NED", "UEN", "SEU", "DES"], "+Y"),
    (["NUE", "NED", "NDW", "NWU"], "+X"),
]
ALL_POSITIONS = sorted({p for chain, _ in TABLE1 for p in chain})


@pytest.mark.parametrize("letters", ALL_POSITIONS)
def test_orientation_is_rotation_and_accelerometers_see_gravity_on_the_vertical_axis(letters):
    dcm = orientation.orientation_to_dcm(letters)
    np.testing.assert_allclose(dcm.T @ dcm, np.eye(3), atol=1e-15)
    assert np.linalg.det(dcm) == pytest.approx(1.0)
    g = 9.8
    specific_force_body = dcm.T @ np.array([0.0, 0.0, g])  # at rest the accelerometers read +g up
    expected = np.array([g if c == "U" else -g if c == "D" else 0.0 for c in letters])
    np.testing.assert_allclose(specific_force_body, expected, atol=1e-12)


def test_use_x_accelerometer_reads_plus_g_and_nue_y_reads_plus_g():
    assert (orientation.orientation_to_dcm("USE").T @ [0, 0, 1])[0] == pytest.approx(1.0)
    assert (orientation.orientation_to_dcm("NUE").T @ [0, 0, 1])[1] == pytest.approx(1.0)
    # the Earth rate is seen by the axis pointing north (x in NUE)
    w = orientation.orientation_to_dcm("NUE").T @ earth.earth_rate_enu(np.radians(37.5))
    assert w[0] == pytest.approx(earth.EARTH_RATE * np.cos(np.radians(37.5)))


@pytest.mark.parametrize("chain,axis", TABLE1)
def test_table1_rotations_lead_from_each_position_to_the_next(chain, axis):
    dcm = orientation.orientation_to_dcm(chain[0])
    for nxt in chain[1:]:
        dcm = orientation.rotate_body(dcm, axis, np.pi / 2)
        assert orientation.dcm_to_orientation(dcm, tol_deg=1e-6) == nxt


@pytest.mark.parametrize("bad,why", [("NUW", "left-handed"), ("NNE", "degenerate"), ("NUQ", "unknown"),
                                     ("NU", "three letters")])
def test_bad_orientations_are_rejected_with_reason(bad, why):
    with pytest.raises(orientation.OrientationError, match=why):
        orientation.orientation_to_dcm(bad)


def test_axis_strings():
    np.testing.assert_array_equal(orientation.parse_axis("-Y"), [0, -1, 0])
    np.testing.assert_array_equal(orientation.parse_axis("+Z"), [0, 0, 1])
    for bad in ("+W", "++X", "", 3, "Z", "+x", " +X"):  # spelled exactly as the recording format spells them
        with pytest.raises(orientation.OrientationError):
            orientation.parse_axis(bad)


def test_rotation_vector_inverts_small_rotation():
    rng = np.random.default_rng(1)
    for _ in range(20):
        v = rng.normal(size=3)
        v *= rng.uniform(0, 3.0) / np.linalg.norm(v)  # angles below pi
        np.testing.assert_allclose(rotations.rotation_vector(rotations.rotation_matrices(v)), v, atol=1e-12)


def test_normal_gravity_wgs84_reference_values():
    # Somigliana normal gravity at the equator, the poles and 45 deg (WGS-84, NIMA TR8350.2)
    assert earth.normal_gravity(0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert earth.normal_gravity(np.pi / 2) == pytest.approx(9.8321849378, abs=1e-9)
    # Somigliana's other closed form, with the semi-axes a, b and the polar gravity
    a, b = 6378137.0, 6356752.314245
    gamma_e, gamma_p = 9.7803253359, 9.8321849378
    for lat in np.radians([10.0, 37.5, 45.0, 80.0]):
        c2, s2 = np.cos(lat) ** 2, np.sin(lat) ** 2
        closed = (a * gamma_e * c2 + b * gamma_p * s2) / np.sqrt(a**2 * c2 + b**2 * s2)
        assert earth.normal_gravity(lat) == pytest.approx(closed, abs=2e-9)
    # free-air gradient about -3.086e-6 m/s^2 per metre
    lat = np.radians(37.5)
    grad = (earth.normal_gravity(lat, 1000.0) - earth.normal_gravity(lat)) / 1000.0
    assert grad == pytest.approx(-3.086e-6, rel=2e-3)
