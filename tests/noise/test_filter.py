"""The compiled Kalman filter (:mod:`noise.filter`) against an independent oracle: the step-by-step NumPy
filter and discretisation the package used before the filter was compiled, on every state layout (raw noise, Gauss-Markov biases,
unmodelled terms, free velocity offsets), compiled and on CasADi's virtual machine."""

import dataclasses

import numpy as np
import pytest

from casadi_sins.calibrate.nlp.graph import build_graph
from casadi_sins.calibrate.steps import default_observation_spacing
from casadi_sins.model.noise import SensorNoise
from casadi_sins.noise.kalman import NoiseSystem
from casadi_sins.noise.observations import Observation, ObservationKind
from casadi_sins.noise.statespace import (ACC, DV, GYRO_FLOOR, PHI, PM, ROTATION_METHOD_ERROR, VELOCITY_FLOOR,
                                          GroupTrack, Layout, gauss_markov_integrals)


def oracle_whiten(system: NoiseSystem, columns: np.ndarray, noise: SensorNoise):
    """The filter step by step in NumPy: ``(whitened columns, log det)``."""
    noise = noise.complete()
    columns = np.asarray(columns, dtype=float)
    columns = columns[:, None] if columns.ndim == 1 else columns
    run = _Filter(system, noise, columns)
    previous_end = None
    for track in system.tracks:
        run.start_group(track, previous_end)
        phi, q = oracle_transitions(system, track, noise, run.layout)
        mids = track.segment_mid
        at_step = track.observations_at
        for k in range(len(track.step_dt)):
            run.start_step(track, k)
            run.predict(phi[k], q[k])
            if k in mids:
                run.keep_middle_attitude()
            for obs in at_step.get(k, ()):
                run.observe(track, k, obs)
        previous_end = track.end_time
    return run.out, run.log_det


_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)


def oracle_transitions(system, track, noise, layout):
    """The discretisation as the package wrote it before (combined, per step): ``Phi`` and ``Q`` (M, n, n)."""
    n = layout.n
    h = track.step_dt
    c = track.attitude
    m = len(h)
    eye3 = np.eye(3)
    phi = np.tile(np.eye(n), (m, 1, 1))
    phi[:, PHI, PHI] -= system.earth_cross[None] * h[:, None, None]
    phi[:, DV, PHI] = system.f_cross[None] * h[:, None, None]
    # white gyro noise: Phi(u) G = V0 + V1 u (u = time to the end of the step); white accelerometer noise: W0
    q_g = noise.gyro_arw**2
    v0 = np.zeros((m, n, 3))
    v0[:, PHI] = -c
    v0[:, ACC] = eye3
    v1 = np.zeros((m, n, 3))
    v1[:, DV] = -system.f_cross @ c
    h1, h2, h3 = (h[:, None, None] ** k / k for k in (1, 2, 3))
    a = (v0 * q_g) @ np.swapaxes(v0, 1, 2)
    b = (v0 * q_g) @ np.swapaxes(v1, 1, 2)
    d = (v1 * q_g) @ np.swapaxes(v1, 1, 2)
    q = a * h1 + (b + np.swapaxes(b, 1, 2)) * h2 + d * h3
    w0 = np.zeros((m, n, 3))
    w0[:, DV] = c
    q += (w0 * noise.accel_vrw**2) @ np.swapaxes(w0, 1, 2) * h1
    if layout.unmodelled:  # unmodelled acceleration: constant within a static segment
        phi[:, DV, layout.ua] = eye3 * (h * track.static)[:, None, None]
    if layout.markov:
        for sensor, sl, sigma, tau in (("gyro", layout.bg, noise.gyro_bias_instability, noise.gyro_bias_tau),
                                       ("accel", layout.ba, noise.accel_bias_instability, noise.accel_bias_tau)):
            beta, gamma1, gamma2 = gauss_markov_integrals(h, tau)
            phi[:, sl, sl] = eye3 * beta[:, None, None]
            if sensor == "gyro":
                phi[:, PHI, sl] = -c * gamma1[:, None, None]
                phi[:, ACC, sl] = eye3 * gamma1[:, None, None]
                phi[:, DV, sl] = -(system.f_cross @ c) * gamma2[:, None, None]
            else:
                phi[:, DV, sl] = c * gamma1[:, None, None]
            if sigma == 0.0:
                continue
            # Q = (2 sigma^2 / tau) int_0^h Phi(u) G Phi(u)^T... du by 6-point Gauss-Legendre (smooth integrand)
            for x, wgt in zip(_GAUSS_X, _GAUSS_W):
                bu, g1, g2 = gauss_markov_integrals(h * (1.0 + x) / 2.0, tau)
                col = np.zeros((m, n, 3))
                col[:, sl] = eye3 * bu[:, None, None]
                if sensor == "gyro":
                    col[:, PHI] = -c * g1[:, None, None]
                    col[:, ACC] = eye3 * g1[:, None, None]
                    col[:, DV] = -(system.f_cross @ c) * g2[:, None, None]
                else:
                    col[:, DV] = c * g1[:, None, None]
                q += (2.0 * sigma**2 / tau) * (wgt * h / 2.0)[:, None, None] * (col @ np.swapaxes(col, 1, 2))
    return phi, q


class _Filter:
    """One pass of the Kalman filter over the tracks: state, covariance, whitened rows, log-likelihood."""

    def __init__(self, system, noise: SensorNoise, columns: np.ndarray):
        self.system, self.noise, self.columns = system, noise, columns
        self.layout = Layout.of(noise)
        n = self.layout.n
        self.out = np.zeros_like(columns)
        self.x = np.zeros((n, columns.shape[1]))
        self.p = np.zeros((n, n))
        if self.layout.markov:
            self.p[self.layout.bg, self.layout.bg] = np.eye(3) * noise.gyro_bias_instability**2
            self.p[self.layout.ba, self.layout.ba] = np.eye(3) * noise.accel_bias_instability**2
        self.q_a = noise.accel_quantization**2
        self.q_g = noise.gyro_quantization**2
        self.log_det = 0.0
        self.offset = np.zeros((3, columns.shape[1]))  # observed velocity of a free offset's reference
        self.free_pending = False

    def _reset(self, *slices):
        for sl in slices:
            self.x[sl] = 0.0
            self.p[sl, :] = 0.0
            self.p[:, sl] = 0.0

    def start_group(self, track: GroupTrack, previous_end: float | None) -> None:
        """A new group: the biases wander on since the last one; attitude free (estimated), velocity zero
        up to the accelerometers' remainder."""
        noise, layout, p = self.noise, self.layout, self.p
        if layout.markov and previous_end is not None:
            for sl, sigma, tau in ((layout.bg, noise.gyro_bias_instability, noise.gyro_bias_tau),
                                   (layout.ba, noise.accel_bias_instability, noise.accel_bias_tau)):
                beta = gauss_markov_integrals(max(track.start_time - previous_end, 0.0), tau)[0]
                self.x[sl] *= beta
                p[sl, :] *= beta
                p[:, sl] *= beta
                p[sl, sl] += np.eye(3) * sigma**2 * (1.0 - beta**2)
        self._reset(PHI, DV, ACC, PM, *((layout.ua,) if layout.unmodelled else ()))
        c0 = track.attitude[0]
        self.p[DV, DV] = (c0 * self.q_a) @ c0.T
        self.offset = np.zeros((3, self.columns.shape[1]))
        self.free_pending = False

    def start_step(self, track: GroupTrack, k: int) -> None:
        """At a static segment's first step: the rotation's velocity error, a new gyro angle and unmodelled
        acceleration; a free velocity offset from here on when the rotation's step is not used."""
        layout = self.layout
        if track.segment_start[k] and k > 0:
            self.p[DV, DV] += np.eye(3) * (ROTATION_METHOD_ERROR**2 + self.noise.unmodelled_step**2)
        if track.segment_start[k]:
            self._reset(ACC, *((layout.ua,) if layout.unmodelled else ()))
            if layout.unmodelled:
                self.p[layout.ua, layout.ua] = np.eye(3) * self.noise.unmodelled_acceleration**2
        self.free_pending |= bool(track.free_velocity[k])

    def predict(self, phi: np.ndarray, q: np.ndarray) -> None:
        """Propagate state and covariance over one step."""
        self.x = phi @ self.x
        self.p = phi @ self.p @ phi.T + q

    def keep_middle_attitude(self) -> None:
        """Keep the attitude error of the step whose attitude the segment's gyro mean uses."""
        x, p = self.x, self.p
        x[PM] = x[PHI]
        p[PM, :] = p[PHI, :]
        p[:, PM] = p[:, PHI]
        p[PM, PM] = p[PHI, PHI]

    def observe(self, track: GroupTrack, k: int, obs: Observation) -> None:
        """Whiten one observation's three rows and update the state with it."""
        n = self.layout.n
        row = obs.row
        if obs.kind == ObservationKind.VELOCITY:
            ck = track.attitude[k]
            r_obs = (ck * self.q_a) @ ck.T + np.eye(3) * VELOCITY_FLOOR
            if self.free_pending:
                # a free velocity offset: this observation only sets it.  From here on the velocity counts
                # from it, so its error restarts at minus its remainder.
                self.offset = self.columns[row:row + 3].copy()
                self._reset(DV)
                self.p[DV, DV] = r_obs
                self.out[row:row + 3] = 0.0
                self.free_pending = False
                return
            h = np.zeros((3, n))
            h[:, DV] = np.eye(3)
            reference = self.offset
        else:
            duration = track.segment_duration[obs.segment]
            r_obs = np.diag(2.0 * self.q_g / duration**2 + track.segment_sway.get(obs.segment, 0.0)
                            + self.noise.unmodelled_rate**2 + GYRO_FLOOR)
            # mean rate - C_nav^T w_ie: the gyro angle over the duration, and the navigated attitude's error
            # at the middle turning the Earth rate (C^T [w_ie x] phi)
            h = np.zeros((3, n))
            h[:, ACC] = np.eye(3) / duration
            h[:, PM] = track.attitude[track.segment_mid_of[obs.segment]].T @ self.system.earth_cross
            reference = 0.0
        self._update(row, h, r_obs, reference)

    def _update(self, row: int, h: np.ndarray, r_obs: np.ndarray, reference) -> None:
        p = self.p
        ph = p @ h.T  # P H^T
        s = h @ ph + r_obs
        s = 0.5 * (s + s.T)
        chol = np.linalg.cholesky(s)
        innovation = self.columns[row:row + 3] - reference - h @ self.x
        self.out[row:row + 3] = np.linalg.solve(chol, innovation)
        self.log_det += 2.0 * float(np.sum(np.log(np.diag(chol))))
        gain = np.linalg.solve(s, ph.T).T  # P H^T S^-1
        self.x = self.x + gain @ innovation
        i_kh = np.eye(self.layout.n) - gain @ h
        self.p = i_kh @ p @ i_kh.T + gain @ r_obs @ gain.T


@pytest.fixture(scope="module")
def short_graph(short_problem):
    """A short simulated recording's graph, linearised at its reference."""
    from casadi_sins.sim import simulate

    rec = simulate(short_problem, seed=3).recording
    from casadi_sins.calibrate.initial import rough_parameters

    graph = build_graph(rec, rough_parameters(rec).values, default_observation_spacing(rec))
    z = np.zeros(graph.n_variables)
    r, jac = graph.jacobian(z)
    return rec, graph, np.column_stack([r, jac]), graph.trajectory(z)


LAYOUTS = {
    "white": {},
    "quantized": {"accel_quantization": 2e-5, "gyro_quantization": 1e-7},
    "markov": {"gyro_bias_instability": 1e-8, "gyro_bias_tau": 300.0, "accel_bias_instability": 1e-6,
               "accel_bias_tau": 200.0},
    "unmodelled": {"unmodelled_acceleration": 1e-6, "unmodelled_rate": 1e-9, "unmodelled_step": 1e-4},
    "everything": {"gyro_bias_instability": 1e-8, "accel_bias_instability": 1e-6, "unmodelled_acceleration": 1e-6,
                   "unmodelled_rate": 1e-9, "unmodelled_step": 1e-4, "accel_quantization": 2e-5},
}


def _noise(**changes):
    base = SensorNoise(gyro_arw=np.array([2e-7, 3e-7, 2.5e-7]), accel_vrw=np.array([5e-5, 4e-5, 6e-5]),
                       gyro_quantization=0.0, accel_quantization=0.0, gyro_bias_instability=0.0,
                       accel_bias_instability=0.0)
    return dataclasses.replace(base, **changes)


@pytest.mark.parametrize("free_offsets", [False, True])
@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_compiled_filter_equals_the_numpy_oracle(short_graph, layout, free_offsets):
    """Every state layout, with and without free velocity offsets (rotation steps dropped): the whitened
    residual and Jacobian columns and the log-determinant agree with the step-by-step filter to round-off,
    for many columns and for one."""
    rec, graph, columns, trajectory = short_graph
    system = NoiseSystem(graph.tracks(trajectory, not free_offsets), rec.site.g, rec.site.earth_rate)
    if free_offsets:
        assert any(t.free_velocity.any() for t in system.tracks)
    noise = _noise(**LAYOUTS[layout])
    expected, log_det = oracle_whiten(system, columns, noise)
    scale = np.abs(expected).max(axis=0)
    for cols in (columns, columns[:, 0]):
        white = system.whiten(cols, noise)
        got = white.columns if cols.ndim == 2 else white.columns[:, :1]
        want = expected if cols.ndim == 2 else expected[:, :1]
        assert np.all(np.abs(got - want) <= 1e-9 * scale[:want.shape[1]])
        assert white.log_det == pytest.approx(log_det, rel=1e-12)


def test_repeated_whitening_from_variance_components_equals_the_oracle(short_graph):
    """A likelihood search whitens one system under many noise levels: from the second whitening on, the
    step covariances come from the variance components composed once; they equal the direct ones."""
    rec, graph, columns, trajectory = short_graph
    system = NoiseSystem(graph.tracks(trajectory, True), rec.site.g, rec.site.earth_rate)
    base = _noise(**LAYOUTS["everything"])
    for factor in (1.0, 3.0, 0.2):
        noise = dataclasses.replace(base, gyro_arw=base.gyro_arw * factor, unmodelled_step=1e-4 / factor,
                                    accel_bias_instability=1e-6 * factor)
        expected, log_det = oracle_whiten(system, columns, noise)
        white = system.whiten(columns, noise)
        assert np.all(np.abs(white.columns - expected) <= 1e-9 * np.abs(expected).max(axis=0))
        assert white.log_det == pytest.approx(log_det, rel=1e-12)
    assert system.components, "the components were not used"


def test_filter_on_the_virtual_machine_equals_the_compiled_one(short_graph, monkeypatch):
    """Without a C compiler the same CasADi step runs on CasADi's virtual machine: the same numbers."""
    from casadi_sins.noise import filter as kalman_filter

    rec, graph, columns, trajectory = short_graph
    system = NoiseSystem(graph.tracks(trajectory, True), rec.site.g, rec.site.earth_rate)
    noise = _noise(**LAYOUTS["markov"])
    compiled = system.whiten(columns, noise)
    kalman_filter.filter_chain.cache_clear()
    monkeypatch.setenv("CASADI_SINS_NO_COMPILE", "1")
    try:
        virtual = NoiseSystem(system.tracks, rec.site.g, rec.site.earth_rate).whiten(columns, noise)
        assert "External" not in kalman_filter.filter_chain(18, 40, kalman_filter.transition_pattern(
            Layout(True, False)).tobytes()).block.class_name()
    finally:
        kalman_filter.filter_chain.cache_clear()
    assert np.all(np.abs(virtual.columns - compiled.columns) <= 1e-12 * np.abs(compiled.columns).max(axis=0))
    assert virtual.log_det == pytest.approx(compiled.log_det, rel=1e-13)
