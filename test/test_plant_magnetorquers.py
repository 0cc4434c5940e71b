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
The plant (torquefree_ros.Plant) stepped with a magnetorquer dipole, ``step(dipole=...)``.

It follows the node's rules bit for bit (the effect's hold and refusals, the same integrator), a
batch body is bit for bit the body alone, the command holds up to its timeout's sample and no
further, a refused dipole changes nothing, and a B-dot law on the plant detumbles the library's
bdot_detumble body as the node's example controller does.
"""

import numpy as np
import pytest
from torquefree_ros import load_scene, Plant
from torquefree_ros.core.effects.sensors import environment_at
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping

RATE = 2.0
ORBIT = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.0,
    'inclination': 1.6999506914424771,
}
# three rods along the axes and a skewed fourth: the allocation is least-norm, not the identity
RODS = [
    {'axis': [1.0, 0.0, 0.0], 'max_dipole': 0.2},
    {'axis': [0.0, 1.0, 0.0], 'max_dipole': 0.2},
    {'axis': [0.0, 0.0, 1.0], 'max_dipole': 0.15},
    {'axis': [1.0, 1.0, 1.0], 'max_dipole': 0.1},
]


def _rod_scene(
    inertia=(0.020, 0.021, 0.005),
    omega=(0.1, -0.1, 0.1),
    timeout=1.2,
    max_command=5.0,
    torque=False,
):
    effects = [{'magnetorquers': {'rods': RODS, 'timeout': timeout, 'max_command': max_command}}]
    if torque:
        effects.append({'torque_command': {'timeout': 0.35, 'max_torque': 1e-3}})
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega)},
            'orbit': ORBIT,
            'effects': effects,
            'accuracy': 1e-10,
        }
    )


def _dipoles(count, seed=0):
    rng = np.random.default_rng(seed)
    # up to twice the rods' limits: some rods saturate
    dipoles = 0.2 * rng.standard_normal((count, 3))
    # no new command for a while (past the 1.2 s timeout at 2 Hz): the last holds, then zero
    dipoles[5:10] = np.nan
    return dipoles


def test_dipole_commands_step_as_the_node_does_bit_for_bit():
    """
    The node's path without DDS (the effect's hold, sealed, a Simulation) and the plant.

    Dipoles some rods saturate under, a gap past the timeout, a torque_command beside them: the
    same samples, bit for bit; the dipole the Simulation reports applied (``magnetorquer_dipole``)
    is the effect's allocation of the one given, and the rods did turn the body.
    """
    scene = _rod_scene(torque=True)
    simulation = Simulation(scene.propagator(), RATE)
    holds = dict(simulation.command_holds)
    (rods,) = [e for e in holds if e.name == 'magnetorquers']
    (torque_hold,) = [h for e, h in holds.items() if e.name == 'torque_command']
    plant = Plant(scene, RATE)
    assert plant.takes_dipole and plant.takes_torque and not plant.takes_wheels
    torques = 1e-5 * np.random.default_rng(1).standard_normal((30, 3))
    torques[12:20] = np.nan
    saturated = 0
    for k, dipole in enumerate(_dipoles(30)):
        given = None if np.isnan(dipole[0]) else dipole
        torque = None if np.isnan(torques[k][0]) else torques[k]
        if given is not None:
            assert rods.receive(rods.hold.stamp_ns(k), rods.hold.frame_id, given)[0]
            saturated += not np.allclose(rods.applied_dipole(given), given, rtol=0, atol=1e-15)
        if torque is not None:
            assert torque_hold.receive(torque_hold.stamp_ns(k), torque)[0]
        for hold in holds.values():
            hold.seal(k)
        block = simulation.samples(k + 1, 1, outputs=False)
        state = plant.step(torque, dipole=given)
        np.testing.assert_array_equal(state.omega_B, block.omega_B[0])
        np.testing.assert_array_equal(state.q_NB, block.q_NB[0])
        np.testing.assert_array_equal(state.internal, block.internal[0])
    assert saturated >= 5  # (the clipping took part)
    # the dipole alone moves the rate: the same commands without it end elsewhere
    without = Plant(scene, RATE)
    for k in range(30):
        without.step(None if np.isnan(torques[k][0]) else torques[k])
    assert np.abs(without.state.omega_B - plant.state.omega_B).max() > 1e-4


def test_a_batch_of_rod_bodies_is_bit_for_bit_each_alone():
    rng = np.random.default_rng(5)
    scenes = [
        _rod_scene(
            inertia=(0.020, 0.021, 0.005) * (1 + 0.05 * rng.random(3)),
            omega=0.1 * rng.standard_normal(3),
            timeout=timeout,
        )
        for timeout in (0.4, 1.2, 3.0, 0.9)
    ]
    batch = Plant(scenes, RATE)
    alone = [Plant(scene, RATE) for scene in scenes]
    dipoles = 0.2 * rng.standard_normal((16, 4, 3))
    for k, step in enumerate(dipoles):
        given = None if 6 <= k < 12 else step  # (each body's own timeout within the gap)
        states = batch.step(dipole=given)
        for b, plant in enumerate(alone):
            state = plant.step(dipole=None if given is None else given[b])
            for got, expected in zip(states, state):
                np.testing.assert_array_equal(got[b], expected)
    assert batch.state.omega_B.shape == (4, 3)


@pytest.mark.parametrize(
    'timeout, boundary',
    [
        (1.5, 3),  # t_3 - t_0 = 1.5 s: timed out exactly at sample 3 (the rule is >=)
        (1.2, 3),  # t_2 = 1.0 < 1.2 <= t_3 = 1.5
        (0.4, 1),  # in force on interval 0 only
    ],
)
def test_a_dipole_holds_until_its_timeout_s_sample_then_the_rods_are_off(timeout, boundary):
    """
    A dipole given at sample 0 holds on ``[t_k, t_k+1)`` while ``t_k < timeout``, then zero.

    The reference gives the same dipole explicitly at every sample before ``boundary`` and a zero
    one from it on: bit for bit the same; holding one interval longer is not.
    """
    scene = _rod_scene(timeout=timeout)
    dipole = [0.15, -0.1, 0.05]
    plant = Plant(scene, RATE)
    explicit = Plant(scene, RATE)
    longer = Plant(scene, RATE)
    for k in range(boundary + 3):
        state = plant.step(dipole=dipole if k == 0 else None)
        reference = explicit.step(dipole=dipole if k < boundary else [0.0, 0.0, 0.0])
        one_more = longer.step(dipole=dipole if k <= boundary else [0.0, 0.0, 0.0])
        for got, expected in zip(state, reference):
            np.testing.assert_array_equal(got, expected)
    # (one interval of the dipole's torque, ~1e-5 N m on 0.02 kg m^2 for 0.5 s, moves the rate
    # by ~1e-4 rad/s: far above the integration's 1e-10)
    assert np.abs(one_more.omega_B - state.omega_B).max() > 1e-6


@pytest.mark.parametrize(
    'dipole, reason',
    [
        ([np.nan, 0.0, 0.0], r'dipole: not finite: a NaN or infinite component'),
        ([0.0, np.inf, 0.0], r'dipole: not finite'),
        ([0.0, 0.0], r'dipole: expected shape \(3,\) \(A m\^2, body frame\), got \(2,\)'),
        ([[0.0, 0.0, 0.0]], r'dipole: expected shape \(3,\)'),
        ('abc', r'dipole: expected numbers of shape \(3,\)'),
        (
            [0.0, -5.5, 0.0],
            r'dipole: too large: a dipole component exceeds max_command 5 A m\^2: '
            r'\[0.0, -5.5, 0.0\]',
        ),
    ],
)
def test_a_refused_dipole_raises_as_the_node_refuses_and_changes_nothing(dipole, reason):
    plant = Plant(_rod_scene(torque=True), RATE)
    plant.step(dipole=[0.1, 0.0, 0.0])
    before, k = plant.state, plant.k
    with pytest.raises(ValueError, match=reason) as error:
        plant.step([1e-4, 0.0, 0.0], dipole=dipole)  # (the torque is not taken either)
    assert plant.k == k
    for now, then in zip(plant.state, before):
        np.testing.assert_array_equal(now, then)
    again = Plant(_rod_scene(torque=True), RATE)
    again.step(dipole=[0.1, 0.0, 0.0])
    np.testing.assert_array_equal(plant.step().omega_B, again.step().omega_B)
    # the node's effect refuses the same command (a well-shaped one) with the same reason
    if np.shape(dipole) == (3,):
        (rods,) = [e for e in _rod_scene().propagator().effects if e.name == 'magnetorquers']
        accepted, why = rods.receive(0, rods.hold.frame_id, dipole)
        assert not accepted and str(error.value).startswith(f'dipole: {why}: ')


def test_a_batch_names_the_refused_body_and_a_scene_without_rods_takes_no_dipole():
    batch = Plant([_rod_scene(), _rod_scene(max_command=0.5)], RATE)
    too_large = r'dipole: too large: .* max_command 0.5 A m\^2 \(body 1\)'
    with pytest.raises(ValueError, match=too_large):
        batch.step(dipole=[[0.0, 0.0, 0.7], [0.0, 0.0, 0.7]])
    with pytest.raises(ValueError, match=r'dipole: expected shape \(2, 3\)'):
        batch.step(dipole=[0.0, 0.0, 0.1])
    assert batch.k == 0
    plant = Plant('explorer1', 1.0)
    assert not plant.takes_dipole
    with pytest.raises(ValueError, match='dipole: the scene takes no dipole'):
        plant.step(dipole=[0.0, 0.0, 0.1])


def _field_B(place, state, t: float) -> np.ndarray:
    """Return the field in the body frame, ``R(q)^T B_N(t)`` (T): the magnetometer's, exact."""
    b_N = environment_at(place, np.array([t]), 'igrf')[0]
    return np.array(
        quaternion.rotate_values(quaternion.conjugate_values(state.q_NB.tolist()), b_N.tolist())
    )


def test_a_b_dot_law_on_the_plant_detumbles_the_bdot_detumble_body():
    """
    B-dot on the plant, ``m = -k dB_B/dt`` (examples/bdot_detumble_controller.py's law and gain).

    The body-frame field from the plant's attitude and the scene's orbit; ``dB_B/dt`` from two
    successive samples at 1 Hz; the dipole scaled down as a whole to the rods' 0.2 A m^2. The law
    takes out the rate across the field (theory: the example's docstring), so the mean rate over
    each 300 s window falls below the one before, by at least 12 % as the example's test states
    (measured over these 1200 s: 61 %, 31 %, 18 %). The free body's mean stays within 1 % of its
    10 deg/s (its rate's norm varies along the torque-free motion, its momentum does not): the
    fall is the rods'.
    """
    scene = load_scene('bdot_detumble')
    plant = Plant(scene, 1.0)
    gain, largest = 1.0e5, 0.2  # A m^2 s/T, A m^2: the example's
    state = plant.state
    rates = [np.linalg.norm(state.omega_B)]
    last = None
    for _ in range(1199):
        field = _field_B(scene.orbit, state, plant.t)
        dipole = np.zeros(3) if last is None else -gain * (field - last) / (1.0 / plant.rate)
        last = field
        peak = np.abs(dipole).max()
        dipole = dipole * (largest / peak) if peak > largest else dipole
        state = plant.step(dipole=dipole)
        rates.append(np.linalg.norm(state.omega_B))
    means = np.reshape(rates, (-1, 300)).mean(axis=1)
    assert np.all(means[1:] < 0.88 * means[:-1]), np.degrees(means)
    free = Plant(scene, 1.0)
    free_rates = np.append(
        np.linalg.norm(free.state.omega_B), np.linalg.norm(free.run(1199.0).omega_B, axis=1)
    )
    np.testing.assert_allclose(
        free_rates.reshape(-1, 300).mean(axis=1), np.radians(10.0), rtol=0.01
    )
