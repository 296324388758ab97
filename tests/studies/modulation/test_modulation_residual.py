"""What a rotation cancels: Yu and Ruan 2014 eqs. 7-8 and section 2.3, Guan et al. 2023 eqs. 32-35."""

import math

import numpy as np
import pytest

from casadi_sins.core import earth, units
from casadi_sins.model import registry as R
from casadi_sins.studies.modulation import model as M
from casadi_sins.studies.modulation.covariance import propagate
from casadi_sins.studies.modulation.residual import equivalent_drift, piece_integral, sensor_vector, turn_forms
from casadi_sins.studies.modulation.schemes import load_scheme, parse_scheme, turn

W = math.radians(6.0)  # table rate of the single-axis cases
ARCSEC, DEG_PER_H = units.ARCSEC, units.DEG_PER_H


def continuous(rate_deg_s=6.0):
    return parse_scheme({"step": [{"axis": "z", "angle_deg": 360.0, "rate_deg_s": rate_deg_s}]})


def drift(scheme, site, part="total", **errors):
    return equivalent_drift(scheme, site, part) @ sensor_vector(**errors)


# --------------------------------------------------------------------------- Yu and Ruan 2014, eqs. 7-8
@pytest.mark.parametrize("axis", [[0, 0, 1], [0, 1, 0]])
def test_a_half_turn_error_has_five_forms_and_only_constant_and_sin_survive(yu_ruan_site, axis):
    """Eq. 7: the navigation-frame gyro error of a turn is const + sin a + cos a + sin 2a + cos 2a;
    eq. 8: over a 180 deg turn only the constant and the sin a terms integrate to non-zero."""
    rng = np.random.default_rng(3)
    x = np.zeros(len(M.SHEET_NAMES))
    x[R.GYRO_BIAS.start:R.GYRO_MISALIGN.stop] = rng.normal(0, 1e-5, 12)
    rate = math.radians(20.0)
    half = turn(0.0, math.pi / rate, np.eye(3), np.array(axis, float), rate)
    forms = turn_forms(half, yu_ruan_site, x)
    scale = np.abs(np.concatenate([forms[k] for k in ("const", "sin", "cos", "sin2", "cos2")])).max()
    assert forms["misfit"].max() < 1e-12 * scale  # exactly the five forms
    # int_0^pi over the turn: cos a, sin 2a, cos 2a vanish; const -> pi/w, sin a -> 2/w
    expected = forms["const"] * math.pi / rate + forms["sin"] * 2.0 / rate
    np.testing.assert_allclose(piece_integral(half, yu_ruan_site) @ x, expected, rtol=1e-10, atol=1e-18)
    assert np.abs(forms["cos"]).max() > 0.1 * scale  # the cancelled forms are really there


# --------------------------------------------------------------------------- Yu and Ruan 2014, section 2.3
def test_earth_rate_coupling_left_by_the_reversed_8_step_sequence(yu_ruan_site):
    """Section 2.3: with 2 arcsec misalignment and 1e-5 scale error at 45.77 deg, an 8-step sequence whose
    orders 5-8 reverse 1-4 leaves Earth-rate coupling equal to about 0.0001 deg/h of constant drift.

    The exact integral over the period reproduces it on the north and up axes (the scale errors meet
    w_ie,N and w_ie,U at every position: 1.05e-4 and 1.08e-4 deg/h); on the east axis every coupling
    cancels over the four positions (w_ie,E = 0), see docs/modulation.md."""
    scheme = load_scheme("yu-ruan2014-reversal-8")
    errors = {f"gyro_scale_{a}": 1e-5 for a in "xyz"}
    errors.update({n: 2 * ARCSEC for n in R.NAMES if n.startswith("gyro_misalign")})
    east, north, up = drift(scheme, yu_ruan_site, "earth", **errors) / DEG_PER_H
    assert north == pytest.approx(1e-4, rel=0.10)
    assert up == pytest.approx(1e-4, rel=0.10)
    assert abs(east) < 1e-12


def test_each_earth_rate_coupling_term_is_0_0001_deg_h(yu_ruan_site):
    """The size of every term the paper sums: scale 1e-5 or misalignment 2 arcsec times w_ie,N or w_ie,U."""
    w_n, w_u = earth.earth_rate_enu(yu_ruan_site.latitude)[1:]
    for size in (1e-5, 2 * ARCSEC):
        for w in (w_n, w_u):
            assert size * w / DEG_PER_H == pytest.approx(1e-4, rel=0.10)


def test_reversed_sequence_leaves_table_rate_misalignment_coupling_the_improved_one_does_not(yu_ruan_site):
    """Found here, not in the paper: reversing the turn directions at the same positions does not flip
    the sin a term of the table rate through a cross-axis misalignment (t_yz w, t_zy w: a tilt of 2 t per
    half turn), so the rejected sequence drifts east by 2 (t_yz + t_zy) / period-share; the improved
    16-step cancels every term except scale x Earth rate, which no sequence of flips can."""
    t = 2 * ARCSEC
    rejected = drift(load_scheme("yu-ruan2014-reversal-8"), yu_ruan_site, "table", gyro_misalign_yz=t)
    assert abs(rejected[0]) > 0.03 * DEG_PER_H
    improved = load_scheme("yu-ruan2014-improved")
    d = equivalent_drift(improved, yu_ruan_site, "total")
    keep = [R.GYRO_SCALE.start + k for k in range(3)]
    others = np.delete(d, keep + [M.SHEET_NAMES.index(n) for n in R.GROUPS["gyro_asym"].names], axis=1)
    assert np.abs(others).max() < 1e-12
    assert np.abs(d[:, keep]).max() > 1e-6  # the scale x Earth-rate terms remain


def test_improved_scheme_obeys_conclusions_1_and_2(yu_ruan_site):
    """Conclusion 1: each same-axis pair turns the same way about its body axis, so the table rate through
    the scale error (dK_z w) is undone by the pair; conclusion 2: adjacent turns about different axes
    turn opposite ways."""
    scheme = load_scheme("yu-ruan2014-improved")
    signs = [(s.axis, math.copysign(1, s.angle)) for s in scheme.steps]
    for k in range(0, 16, 4):
        block = signs[k:k + 4]
        assert block[0] == block[2] and block[1] == block[3]
        assert block[0][0] != block[1][0] and block[0][1] == -block[1][1]
    pieces = [p for p in _period(scheme) if p.axis is not None]
    x = sensor_vector(gyro_scale_z=1e-5, gyro_scale_y=1e-5)
    for a, b in ((0, 2), (1, 3)):
        pair = (piece_integral(pieces[a], yu_ruan_site, "table") + piece_integral(pieces[b], yu_ruan_site, "table")) @ x
        assert np.abs(pair).max() < 1e-18


def _period(scheme):
    from casadi_sins.studies.modulation.schemes import period_pieces

    return period_pieces(scheme, scheme.start)


# --------------------------------------------------------------------------- Guan et al. 2023, eqs. 32-35
def test_eq32_bias_horizontal_cancelled_vertical_unchanged(guan_site):
    d = drift(continuous(), guan_site, gyro_bias_x=1.0, gyro_bias_y=2.0, gyro_bias_z=3.0)
    np.testing.assert_allclose(d, [0.0, 0.0, 3.0], atol=1e-14)


def test_eq33_scale_factor_symmetric_and_asymmetric(guan_site):
    w_ie = guan_site.earth_rate
    k = 1e-5
    # horizontal symmetric scale errors couple with w_ie,N: half of each is left on the north axis
    np.testing.assert_allclose(drift(continuous(), guan_site, gyro_scale_x=k), [0, k * w_ie[1] / 2, 0], atol=1e-20)
    np.testing.assert_allclose(drift(continuous(), guan_site, gyro_scale_y=k), [0, k * w_ie[1] / 2, 0], atol=1e-20)
    # horizontal asymmetric ones are cancelled
    np.testing.assert_allclose(drift(continuous(), guan_site, gyro_scale_asym_x=k, gyro_scale_asym_y=k), 0, atol=1e-20)
    # z: with w and w_ie,U under continuous rotation; reciprocating undoes the w part, not the asymmetric one
    np.testing.assert_allclose(drift(continuous(), guan_site, gyro_scale_z=k), [0, 0, k * (w_ie[2] + W)], rtol=1e-12)
    recip = load_scheme("single-axis-reciprocating")
    np.testing.assert_allclose(drift(recip, guan_site, gyro_scale_z=k), [0, 0, k * w_ie[2]], rtol=1e-9, atol=1e-20)
    for scheme in (continuous(), recip):
        np.testing.assert_allclose(drift(scheme, guan_site, gyro_scale_asym_z=k), [0, 0, k * W], rtol=1e-3)


@pytest.mark.parametrize("name,modulated", [("gyro_misalign_xy", False), ("gyro_misalign_yx", False),
                                            ("gyro_misalign_xz", True), ("gyro_misalign_zx", True),
                                            ("gyro_misalign_yz", True), ("gyro_misalign_zy", True)])
def test_eq34_misalignment_cancelled_except_xy_yx(guan_site, name, modulated):
    d = drift(continuous(), guan_site, **{name: 3 * ARCSEC})
    if modulated:
        assert np.abs(d).max() < 1e-20
    else:  # the antisymmetric part, a rotation about z, commutes with the turn: -+t w_ie,N / 2 on east
        assert abs(d[0]) == pytest.approx(3 * ARCSEC * guan_site.earth_rate[1] / 2, rel=1e-9)


def test_eq35_white_gyro_noise_is_not_modulated(guan_sheet, guan_site):
    """The attitude covariance of isotropic gyro noise is the same turning or not (a rotation of a white
    isotropic process is the same process)."""
    arw, zero = guan_sheet.gyro_arw, np.zeros(3)
    still = propagate(load_scheme("strapdown"), guan_site, 2.0, arw, zero)
    turning = propagate(load_scheme("single-axis-continuous"), guan_site, 2.0, arw, zero)
    k = int(np.argmin(np.abs(turning.time - still.time[-1])))
    np.testing.assert_allclose(turning.noise["gyro noise"][k], still.noise["gyro noise"][-1], rtol=1e-6, atol=1e-9)
