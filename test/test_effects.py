# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Each effect against an independent check.

Closed forms, conservation laws, textbook frequencies, noise statistics. Numerical propagators are
held to a stated tolerance; the references never go through the code under test.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from torquefree_ros.core.effects import Effect, EFFECTS
from torquefree_ros.core.effects.outputs import IMU_ROW, roll_pitch_yaw
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.propagators import make_propagator
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping

# every check here runs on both paths of the numerical propagators (compiled kernels, scipy/numpy
# reference)
pytestmark = pytest.mark.usefixtures('integrator_path')

NUMERICAL = ['dop853', 'lie_rk4', 'rk4']
TIGHT = {
    'dop853': {'rtol': 1e-12, 'atol': 1e-14},
    'lie_rk4': {'step': 1e-3},
    'rk4': {'step': 1e-3},
}


def scene(inertia, omega, effects, orientation=(0.0, 0.0, 0.0, 1.0), **extra):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega), 'orientation': list(orientation)},
            'effects': effects,
            **extra,
        }
    )


def inertial_momentum(propagator, times):
    omega, q, x = propagator.states(times)
    return quaternion.rotate(q, propagator.momentum_B(omega, x))


# -- external_torque ------------------------------------------------------------------------------
@pytest.mark.parametrize('name', NUMERICAL)
def test_a_torque_fixed_in_the_inertial_frame_changes_H_N_linearly(name):
    """H_N(t) = H_N(0) + tau_N t whatever the attitude does (Euler's law in the inertial frame)."""
    tau_N = np.array([0.02, -0.01, 0.03])
    s = scene(
        [3.0, 2.0, 1.0],
        [0.3, 0.2, 1.0],
        [{'external_torque': {'torque': tau_N.tolist(), 'frame': 'inertial'}}],
        orientation=Rotation.from_rotvec([0.3, -0.2, 0.5]).as_quat().tolist(),
    )
    p = s.propagator(name, **TIGHT[name])
    times = np.linspace(0.0, 8.0, 33)
    H_N = inertial_momentum(p, times)
    expected = H_N[0] + np.outer(times, tau_N)
    # 1e-9 N m s on |H| ~ 2: the integrators' error at TIGHT settings over 8 s
    np.testing.assert_allclose(H_N, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize('name', NUMERICAL)
def test_a_piecewise_schedule_switches_exactly_at_its_breakpoints(name):
    """
    A piecewise torque schedule's switching times, off the fixed-step grid, are hit exactly.

    A body torque along the spin axis of a pure spin: w3(t) is the integral of tau3 / I3, a
    piecewise-linear ramp.
    """
    schedule = [
        {'start': 0.5, 'torque': [0.0, 0.0, 0.2]},
        {'start': 1.2345, 'torque': [0.0, 0.0, -0.1]},
        {'start': 2.71, 'torque': [0.0, 0.0, 0.0]},
    ]
    s = scene([2.0, 3.0, 4.0], [0.0, 0.0, 1.0], [{'external_torque': {'schedule': schedule}}])
    p = s.propagator(name, **({'step': 0.01} if name != 'dop853' else {}))
    times = np.linspace(0.0, 4.0, 401)
    omega, _ = p(times)
    ramp = np.interp(
        times,
        [0.0, 0.5, 1.2345, 2.71, 4.0],
        [
            1.0,
            1.0,
            1.0 + 0.05 * 0.7345,
            1.0 + 0.05 * 0.7345 - 0.025 * 1.4755,
            1.0 + 0.05 * 0.7345 - 0.025 * 1.4755,
        ],
    )
    # linear in t between breakpoints: every method integrates it to rounding
    np.testing.assert_allclose(omega[:, 2], ramp, rtol=0, atol=1e-13)
    np.testing.assert_allclose(omega[:, :2], 0.0, atol=1e-15)


def test_schedule_errors_name_the_segment():
    with pytest.raises(
        ValueError, match=r'effects\[0\]\.external_torque\.schedule\[1\]\.start: .*increasing'
    ):
        scene(
            [3, 2, 1],
            [0, 0, 1],
            [
                {
                    'external_torque': {
                        'schedule': [
                            {'start': 1.0, 'torque': [0, 0, 1]},
                            {'start': 1.0, 'torque': [0, 0, 0]},
                        ]
                    }
                }
            ],
        )
    with pytest.raises(
        ValueError, match=r"effects\[0\]\.external_torque: give either 'torque'.*not both"
    ):
        scene(
            [3, 2, 1],
            [0, 0, 1],
            [
                {
                    'external_torque': {
                        'torque': [0, 0, 1],
                        'schedule': [{'start': 0.0, 'torque': [0, 0, 1]}],
                    }
                }
            ],
        )


# -- gravity_gradient -----------------------------------------------------------------------------
def test_the_gravity_gradient_torque_is_3_mu_over_r3_r_cross_I_r():
    rng = np.random.default_rng(7)
    mu, radius = 3.986004418e14, 7.0e6
    inertia = np.array([[5.0, 0.3, -0.2], [0.3, 4.0, 0.1], [-0.2, 0.1, 3.0]])
    s = scene(
        [5.0, 4.0, 3.0, 0.3, -0.2, 0.1],
        [0.0, 0.0, 0.0],
        [{'gravity_gradient': {'radius': radius, 'gravitational_parameter': mu}}],
    )
    p = s.propagator('dop853')
    (effect,) = p.effects
    n = np.sqrt(mu / radius**3)
    for _ in range(20):
        t = rng.uniform(0.0, 6000.0)
        q = Rotation.random(random_state=rng).as_quat()
        r_N = radius * np.array([np.cos(n * t), np.sin(n * t), 0.0])
        r_B = Rotation.from_quat(q).inv().apply(r_N)
        expected = 3.0 * mu / radius**5 * np.cross(r_B, inertia @ r_B)
        np.testing.assert_allclose(
            effect.torque_B(t, np.zeros(3), q, np.empty(0), 0.0),
            expected,
            rtol=1e-12,
            atol=1e-12 * np.linalg.norm(expected),
        )


def _pitch_in_lvlh(times, q, n):
    """Pitch angle of the body in the LVLH frame (x along-track, y = -orbit normal, z nadir)."""
    angles = []
    for t, qi in zip(times, q):
        r = np.array([np.cos(n * t), np.sin(n * t), 0.0])
        v = np.array([-np.sin(n * t), np.cos(n * t), 0.0])
        lvlh = Rotation.from_matrix(np.column_stack([v, [0.0, 0.0, -1.0], -r]))
        angles.append((lvlh.inv() * Rotation.from_quat(qi)).as_rotvec()[1])
    return np.array(angles)


@pytest.mark.parametrize('name', ['dop853', 'lie_rk4'])
def test_small_pitch_librations_have_the_textbook_frequency(name):
    """sqrt(3 n^2 (Ix - Iz) / Iy) for x along-track, y orbit normal, z radial (Hughes ch. 9)."""
    n, (Ix, Iy, Iz) = 0.0011, (3.0, 4.0, 2.0)
    lvlh0 = Rotation.from_matrix(
        np.column_stack([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
    )
    q0 = (lvlh0 * Rotation.from_rotvec([0.0, 0.01, 0.0])).as_quat()
    s = scene(
        [Ix, Iy, Iz],
        [0.0, -n, 0.0],
        [{'gravity_gradient': {'mean_motion': n}}],
        orientation=q0.tolist(),
    )
    p = s.propagator(
        name, **({'rtol': 1e-12, 'atol': 1e-14} if name == 'dop853' else {'step': 5.0})
    )
    times = np.linspace(0.0, 3 * 2 * np.pi / n, 4001)
    pitch = _pitch_in_lvlh(times, p(times)[1], n)
    crossing = np.where(np.diff(np.sign(pitch)) != 0)[0]
    t_zero = times[crossing] - pitch[crossing] * (times[crossing + 1] - times[crossing]) / (
        pitch[crossing + 1] - pitch[crossing]
    )
    measured = np.pi / np.mean(np.diff(t_zero))
    expected = np.sqrt(3.0 * n * n * (Ix - Iz) / Iy)
    # 1e-4: the finite 0.01 rad amplitude shifts the frequency by ~theta^2/16 ~ 6e-6, and linear
    # interpolation of the zero crossings on a grid of 1/1300 period adds ~1e-5
    assert measured == pytest.approx(expected, rel=1e-4)
    assert np.abs(pitch).max() == pytest.approx(0.01, rel=1e-3)  # a libration, not a tumble


def test_lie_rk4_is_fourth_order_with_attitude_dependent_torques():
    """
    With gravity gradient, lie_rk4 stays fourth order: it needs its stage attitudes.

    The torque depends on q; without the stage attitudes the method would drop to first order in
    the attitude coupling.
    """
    s = scene(
        [3.0, 2.0, 1.0],
        [0.3, 0.2, 0.5],
        [{'gravity_gradient': {'mean_motion': 0.5}}],
        orientation=Rotation.from_rotvec([0.4, 0.1, -0.3]).as_quat().tolist(),
    )
    times = np.array([10.0])
    w_ref, q_ref = s.propagator('dop853', rtol=1e-13, atol=1e-15)(times)
    errors = []
    for step in (0.04, 0.02, 0.01):
        w, q = s.propagator('lie_rk4', step=step)(times)
        errors.append(np.linalg.norm(w - w_ref) + quaternion.angle_between(q, q_ref)[0])
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 3.7) & (orders < 4.3)), orders


# -- damper ---------------------------------------------------------------------------------------
def test_a_damped_prolate_body_ends_in_a_flat_spin_about_its_major_axis():
    """Explorer 1: spin about the minor axis, energy dissipated, |H| kept: the major axis rule."""
    s = scene([1.0, 10.0, 10.5], [2.0, 0.05, 0.0], [{'damper': {'inertia': 0.1, 'damping': 0.05}}])
    p = s.propagator()
    times = np.linspace(0.0, 3000.0, 3001)
    omega, q, x = p.states(times)
    energy = p.energy(omega, x)
    H_N = quaternion.rotate(q, p.momentum_B(omega, x))
    # dT/dt = -c |nu - w|^2 <= 0; 1e-12 relative allows rounding on flat stretches
    assert np.all(np.diff(energy) <= 1e-12 * energy[0])
    np.testing.assert_allclose(
        H_N, np.broadcast_to(H_N[0], H_N.shape), rtol=0, atol=1e-8 * np.linalg.norm(H_N[0])
    )
    final = omega[-1] / np.linalg.norm(omega[-1])
    assert abs(final[2]) > np.cos(np.radians(1.0))  # within 1 degree of the major (z) axis
    # the end state: everything spins together about the major axis, T = H^2 / (2 (I_max + J))
    H = np.linalg.norm(H_N[0])
    assert energy[-1] == pytest.approx(H * H / (2.0 * (10.5 + 0.1)), rel=1e-3)


# -- rotor ----------------------------------------------------------------------------------------
def test_a_rotor_conserves_total_momentum_and_stabilises_the_intermediate_axis():
    omega0 = [0.01, 1.0, 0.01]
    free = scene(
        [1.0, 2.0, 3.0], omega0, [{'external_torque': {'torque': [0.0, 0.0, 0.0]}}]
    ).propagator()
    gyrostat = scene(
        [1.0, 2.0, 3.0], omega0, [{'rotor': {'momentum': 5.0, 'axis': [0.0, 2.0, 0.0]}}]
    ).propagator()
    times = np.linspace(0.0, 60.0, 601)
    H_N = inertial_momentum(gyrostat, times)
    np.testing.assert_allclose(
        H_N, np.broadcast_to(H_N[0], H_N.shape), rtol=0, atol=1e-9 * np.linalg.norm(H_N[0])
    )
    omega, _, x = gyrostat.states(times)
    energy = gyrostat.energy(omega, x)
    np.testing.assert_allclose(energy, energy[0], rtol=1e-9)
    assert np.all(omega[:, 1] > 0.9)  # the wheel keeps the spin on the intermediate axis ...
    assert np.any(free(times)[0][:, 1] < 0.0)  # ... which, without it, flips


# -- imu ------------------------------------------------------------------------------------------
def _allan_deviation(x, rate, m):
    """Overlapping Allan deviation of rate samples x at tau = m / rate (IEEE Std 952)."""
    theta = np.concatenate([[0.0], np.cumsum(x)]) / rate
    d = theta[2 * m:] - 2.0 * theta[m:-m] + theta[: -2 * m]
    tau = m / rate
    return np.sqrt(np.mean(d * d) / (2.0 * tau * tau))


def test_imu_noise_statistics_match_its_parameters():
    rate, N, K = 100.0, 2e-3, 1e-4
    s = scene(
        [3.0, 2.0, 1.0],
        [0.3, 0.2, 1.0],
        [
            {
                'imu': {
                    'gyro_noise_density': N,
                    'gyro_bias_random_walk': K,
                    'initial_bias': [0.01, -0.02, 0.0],
                    'seed': 3,
                }
            }
        ],
    )
    assert s.torque_free and s.propagator().name == 'analytic'
    sim = Simulation(s.propagator(), rate, outputs=s.outputs)
    block = sim.samples(0, 200_000)  # 2000 s
    (rows,) = block.outputs
    error = rows[:, 13:16] - block.omega_B
    # white noise differenced: variance 2 sigma^2 (+ walk steps)
    bias_free = np.diff(error, axis=0)
    sigma = N * np.sqrt(rate)
    # 200 000 samples: the variance estimate has relative standard error sqrt(2/n) ~ 0.3%
    assert np.var(bias_free) == pytest.approx(2 * sigma**2 + K**2 / rate, rel=0.02)
    np.testing.assert_allclose(error[0], [0.01, -0.02, 0.0], atol=5 * sigma)
    # Allan deviation: N / sqrt(tau) at 0.1 s (white noise dominates), K sqrt(tau / 3) at 500 s
    for axis in range(3):
        short = _allan_deviation(error[:, axis], rate, 10)
        assert short == pytest.approx(N / np.sqrt(0.1), rel=0.05)
        slopes = [
            np.log(
                _allan_deviation(error[:, axis], rate, m2)
                / _allan_deviation(error[:, axis], rate, m1)
            )
            / np.log(m2 / m1)
            for m1, m2 in ((1, 10), (10, 100))
        ]
        assert slopes == pytest.approx([-0.5, -0.5], abs=0.05)
    long = np.mean([_allan_deviation(error[:, axis], rate, 50_000) for axis in range(3)])
    # at tau = 500 s (4 independent intervals per axis), one estimate scatters by tens of percent
    assert long == pytest.approx(np.sqrt(N**2 / 500.0 + K**2 * 500.0 / 3.0), rel=0.6)
    # REP 145: orientation and linear acceleration not provided, gyro covariance = white variance
    assert rows.shape[1] == IMU_ROW
    assert np.all(rows[:, 4] == -1.0) and np.all(rows[:, 28] == -1.0)
    np.testing.assert_array_equal(rows[0, 16:25].reshape(3, 3), np.diag([sigma**2] * 3))


def test_imu_samples_do_not_depend_on_how_blocks_are_cut_and_are_seeded():
    s = scene(
        [3.0, 2.0, 1.0],
        [0.3, 0.2, 1.0],
        [{'imu': {'gyro_noise_density': 1e-3, 'gyro_bias_random_walk': 1e-4, 'seed': 11}}],
    )
    whole = Simulation(s.propagator(), 50.0, outputs=s.outputs).samples(0, 1000).outputs[0]
    cut = Simulation(s.propagator(), 50.0, outputs=s.outputs)
    pieces = np.concatenate(
        [cut.samples(first, count).outputs[0] for first, count in ((0, 1), (1, 255), (256, 744))]
    )
    np.testing.assert_array_equal(pieces, whole)
    again = Simulation(s.propagator(), 50.0, outputs=s.outputs)
    # skipping ahead
    np.testing.assert_array_equal(again.samples(500, 10).outputs[0], whole[500:510])
    other = scene(
        [3.0, 2.0, 1.0], [0.3, 0.2, 1.0], [{'imu': {'gyro_noise_density': 1e-3, 'seed': 12}}]
    )
    assert not np.array_equal(
        Simulation(other.propagator(), 50.0, outputs=other.outputs).samples(0, 10).outputs[0],
        whole[:10],
    )


# -- euler_angles ---------------------------------------------------------------------------------
def test_euler_angles_follow_the_spinning_top_equations_of_seed_000():
    """
    The 3-2-1 angles follow the spinning top equations of seed 000.

    Inertial frame aligned with H_N = -H n3: the 3-2-1 angle rates obey

    psi' = -H (sin^2 phi / I2 + cos^2 phi / I3),
    theta' = H/2 (1/I3 - 1/I2) sin 2phi cos theta,
    phi' = H (1/I1 - sin^2 phi / I2 - cos^2 phi / I3) sin theta.
    """
    I1, I2, I3 = 1.0, 2.0, 3.0
    omega0 = np.array([0.4, -0.3, 0.9])
    H_B = np.array([I1, I2, I3]) * omega0
    H = np.linalg.norm(H_B)
    # choose q0 so that R(q0) H_B = (0, 0, -H)
    q0 = Rotation.align_vectors([[0.0, 0.0, -H]], [H_B])[0].as_quat()
    s = scene([I1, I2, I3], omega0.tolist(), [{'euler_angles': {}}], orientation=q0.tolist())
    h = 1e-4
    times = np.concatenate([[t - h, t, t + h] for t in np.linspace(1.0, 9.0, 9)])
    block = Simulation(s.propagator(), 1.0 / h).samples(0, 1)  # the stream needs a rate only
    assert block.outputs == ()  # euler_angles not named on this simulation: nothing computed
    angles = np.unwrap(roll_pitch_yaw(s.propagator()(times)[1]).reshape(-1, 3, 3), axis=1)
    rates = (angles[:, 2] - angles[:, 0]) / (2 * h)
    phi, theta = angles[:, 1, 0], angles[:, 1, 1]
    expected = np.column_stack(
        [
            H * (1 / I1 - np.sin(phi) ** 2 / I2 - np.cos(phi) ** 2 / I3) * np.sin(theta),
            H / 2 * (1 / I3 - 1 / I2) * np.sin(2 * phi) * np.cos(theta),
            -H * (np.sin(phi) ** 2 / I2 + np.cos(phi) ** 2 / I3),
        ]
    )
    # central differences with h = 1e-4 s: truncation ~h^2 |angle'''| ~ 1e-8
    np.testing.assert_allclose(rates, expected, rtol=0, atol=1e-7)


def test_euler_angles_reproduce_the_attitude():
    rng = np.random.default_rng(5)
    q = Rotation.random(200, random_state=rng).as_quat()
    roll, pitch, yaw = roll_pitch_yaw(q).T
    rebuilt = Rotation.from_euler('ZYX', np.column_stack([yaw, pitch, roll]))  # intrinsic z-y'-x''
    assert np.all(quaternion.angle_between(rebuilt.as_quat(), q) < 1e-12)
    assert np.all(np.abs(pitch) <= np.pi / 2)


# -- only what is called for ----------------------------------------------------------------------
def test_a_scene_without_effects_builds_no_effect_and_uses_the_exact_solution(monkeypatch):
    built = []
    original = Effect.__init__

    def counting_init(self, **values):
        built.append(self)
        original(self, **values)

    monkeypatch.setattr(Effect, '__init__', counting_init)
    torque_free = scene([3.0, 2.0, 1.0], [0.3, 0.2, 1.0], [])
    assert built == [] and torque_free.torque_free and torque_free.outputs == ()
    p = torque_free.propagator()
    assert p.name == 'analytic' and p.effects == () and p.dynamics.state_size == 0
    block = Simulation(p, 100.0).samples(0, 10)
    assert block.outputs == () and block.internal.shape == (10, 0)
    only_outputs = scene([3.0, 2.0, 1.0], [0.3, 0.2, 1.0], [{'imu': {}}, {'euler_angles': {}}])
    assert (
        len(built) == 2
        and only_outputs.torque_free
        and only_outputs.propagator().name == 'analytic'
    )


def test_an_effect_that_changes_the_motion_gets_a_numerical_propagator_at_the_scene_accuracy():
    damped = scene(
        [1.0, 10.0, 10.5],
        [2.0, 0.05, 0.0],
        [{'damper': {'inertia': 0.1, 'damping': 0.05}}],
        accuracy=1e-7,
    )
    p = damped.propagator()
    assert p.name == 'dop853' and p.settings == {'rtol': 1e-7, 'atol': 1e-9}
    with pytest.raises(
        ValueError, match=r"propagator: 'analytic' is the exact torque-free solution; .*damper"
    ):
        damped.propagator('analytic')
    assert damped.propagator('lie_rk4').name == 'lie_rk4'


def test_every_registered_effect_has_a_summary_and_declared_parameters():
    assert {
        'external_torque',
        'gravity_gradient',
        'damper',
        'rotor',
        'imu',
        'euler_angles',
    } <= set(EFFECTS)
    for cls in EFFECTS.values():
        assert cls.summary and isinstance(cls.parameters, dict)


def test_make_propagator_keeps_the_torque_free_api():
    w, q = make_propagator([3, 2, 1], [0.3, 0.2, 1.0], [0, 0, 0, 1])(np.array([0.0, 1.0]))
    assert w.shape == (2, 3) and q.shape == (2, 4)
