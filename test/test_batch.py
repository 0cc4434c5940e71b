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
``propagate_batch``: each body exactly as ``propagate`` gives it alone (bit for bit).

Regimes mixed in one batch; shapes and bad input, named by body.
"""

from __future__ import annotations

import numpy as np
import pytest
from torquefree_ros import propagate, propagate_batch

# (inertia, w0): generic, axisymmetric, on and near the separatrix, sphere, pure spins, rest, a
# tensor
BODIES = [
    ([3.0, 2.0, 1.0, 0.0, 0.0, 0.0], [0.3, 0.2, 1.0]),
    ([2.0, 2.0, 1.0, 0.0, 0.0, 0.0], [0.4, -0.1, 0.9]),
    ([1.0, 2.0, 3.0, 0.0, 0.0, 0.0], [1.0, 0.0, 1.0]),  # H^2 = 2 T I2: on the separatrix
    ([1.0, 2.0, 3.0, 0.0, 0.0, 0.0], [1.0, 1e-8, 1.0]),
    ([5.0, 5.0, 5.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3]),
    ([1.0, 2.0, 3.0, 0.0, 0.0, 0.0], [0.0, 2.0, 0.0]),  # pure spin about the intermediate axis
    ([1.0, 2.0, 3.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),  # at rest
    ([4.0, 3.0, 2.5, 0.3, -0.2, 0.4], [0.5, -1.0, 0.7]),
]


def test_each_body_is_what_propagate_gives_alone_bit_for_bit(attitude_path):
    inertia = np.array([b[0] for b in BODIES])
    omega0 = np.array([b[1] for b in BODIES])
    rng = np.random.default_rng(5)
    orientation = rng.normal(size=(len(BODIES), 4))
    orientation /= np.linalg.norm(orientation, axis=1, keepdims=True)
    times = np.linspace(0.0, 50.0, 101)
    omega, q = propagate_batch(inertia, omega0, orientation, times)
    assert omega.shape == (len(BODIES), 101, 3) and q.shape == (len(BODIES), 101, 4)
    for i in range(len(BODIES)):
        alone = propagate(inertia[i], omega0[i], orientation[i], times)
        np.testing.assert_array_equal(omega[i], alone[0])
        np.testing.assert_array_equal(q[i], alone[1])


def test_a_numerical_propagator_and_its_options_pass_through():
    omega, q = propagate_batch(
        [[3.0, 2.0, 1.0]] * 2,
        [[0.3, 0.2, 1.0], [0.1, 0.0, 0.5]],
        [[0, 0, 0, 1]] * 2,
        [0.0, 0.5, 1.0],
        propagator='rk4',
        step=1e-3,
    )
    alone = propagate(
        [3.0, 2.0, 1.0],
        [0.1, 0.0, 0.5],
        [0, 0, 0, 1],
        [0.0, 0.5, 1.0],
        propagator='rk4',
        step=1e-3,
    )
    np.testing.assert_array_equal(omega[1], alone[0])


@pytest.mark.parametrize(
    'inertia, omega, orientation, reason',
    [
        (
            [[1, 2, 3]],
            [[0, 0, 1], [0, 0, 1]],
            [[0, 0, 0, 1]],
            r'angular_velocity: 2 rows for 1 bodies',
        ),
        (
            [[1, 2, 3, 4]],
            [[0, 0, 1]],
            [[0, 0, 0, 1]],
            r'inertia: expected shape \(N, 3 or 6\), got \(1, 4\)',
        ),
        ([[1, 2, 3]], [[0, 0, 1]], [[0, 0, 1]], r'orientation: expected shape \(N, 4\)'),
        (
            [[1, 2, 3], [1, 2, 30]],
            [[0, 0, 1]] * 2,
            [[0, 0, 0, 1]] * 2,
            r'body 1: inertia: .*triangle inequality',
        ),
        ([[1, 2, 3]], [[0, float('nan'), 1]], [[0, 0, 0, 1]], r'body 0: angular_velocity: '),
    ],
)
def test_bad_input_names_the_array_and_the_body(inertia, omega, orientation, reason):
    with pytest.raises(ValueError, match=reason):
        propagate_batch(inertia, omega, orientation, [0.0, 1.0])


def test_a_dispersed_campaign_in_several_stacked_groups_is_bit_for_bit_the_loop(
    monkeypatch, attitude_path
):
    from torquefree_ros.core.propagators import batch

    monkeypatch.setattr(batch, 'GROUP_BODIES', 7)  # several groups, one short
    rng = np.random.default_rng(11)
    count = 50
    inertia = [2.0, 3.0, 4.0] * (1.0 + 0.03 * rng.standard_normal((count, 3)))
    omega0 = rng.normal(0.0, 2.0, (count, 3))
    orientation = rng.normal(size=(count, 4))
    orientation /= np.linalg.norm(orientation, axis=1, keepdims=True)
    # t = 0 twice; long horizons
    times = np.concatenate([[0.0, 0.0], np.sort(rng.uniform(0.0, 1e4, 38))])
    omega, q = propagate_batch(inertia, omega0, orientation, times)
    for i in range(count):
        alone = propagate(inertia[i], omega0[i], orientation[i], times)
        np.testing.assert_array_equal(omega[i], alone[0])
        np.testing.assert_array_equal(q[i], alone[1])


# m > 1/2 and m <= 1/2: the two series
@pytest.mark.parametrize(
    'moments, rate',
    [([2.0, 3.0, 4.0], [0.7, 0.5, 0.6]), ([1.5, 2.0, 3.0], [0.3, 0.2, 1.0])],
    ids=['hyperbolic', 'trigonometric'],
)
def test_passes_and_groups_of_one_kind_are_bit_for_bit_the_loop(
    monkeypatch, moments, rate, attitude_path
):
    """
    Groups and passes give the loop of ``propagate`` bit for bit.

    A campaign of one kind (consecutive bodies: results written in place) in several groups, each
    evaluated in passes of a few samples, is the loop of ``propagate``; so is one body's long
    request evaluated in passes against the same request whole.
    """
    from torquefree_ros.core.propagators import batch
    from torquefree_ros.core.exact.polhode import PolhodeAttitude

    rng = np.random.default_rng(5)
    count = 30
    inertia = moments * (1.0 + 0.01 * rng.standard_normal((count, 3)))
    omega0 = rate + 0.01 * rng.standard_normal((count, 3))
    orientation = np.tile([0.0, 0.0, 0.0, 1.0], (count, 1))
    times = np.linspace(0.0, 300.0, 41)
    whole = propagate(inertia[0], omega0[0], orientation[0], times)
    monkeypatch.setattr(batch, 'GROUP_BODIES', 8)
    # passes of 3 samples in a group, 24 alone
    monkeypatch.setattr(PolhodeAttitude, 'ELEMENTS_PER_PASS', 24)
    omega, q = propagate_batch(inertia, omega0, orientation, times)
    for i in range(count):
        alone = propagate(inertia[i], omega0[i], orientation[i], times)
        np.testing.assert_array_equal(omega[i], alone[0])
        np.testing.assert_array_equal(q[i], alone[1])
        if i == 0:
            np.testing.assert_array_equal(alone[0], whole[0])
            np.testing.assert_array_equal(alone[1], whole[1])


def _random_bodies(rng, count, tensors):
    """Dispersed bodies with some exact symmetries, spins about an axis and rest mixed in."""
    moments = np.sort(rng.uniform(2.0, 4.0, (count, 3)), axis=1)  # within the triangle inequality
    moments[::7, 1] = moments[::7, 0]  # axisymmetric (oblate)
    moments[3::7, 1] = moments[3::7, 2]  # axisymmetric (prolate)
    omega = rng.normal(0.0, 1.5, (count, 3))
    omega[5::11] = [0.0, 0.7, 0.0]  # a pure spin about an axis
    omega[6::13] = 0.0  # at rest
    if not tensors:
        return moments, omega
    rotations = np.linalg.qr(rng.normal(size=(count, 3, 3)))[0]
    tensor = rotations @ (moments[:, :, None] * np.eye(3)) @ np.swapaxes(rotations, 1, 2)
    return tensor[:, [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]], omega


@pytest.mark.parametrize('tensors', [False, True])
def test_random_campaigns_with_symmetries_are_bit_for_bit_the_loop(tensors, attitude_path):
    """
    Random campaigns with exact symmetries give the loop of ``propagate`` bit for bit.

    The constants computed in columns (floats for one body) agree to the last bit for any mix.
    """
    rng = np.random.default_rng(23 + tensors)
    inertia, omega0 = _random_bodies(rng, 120, tensors)
    orientation = rng.normal(size=(120, 4))
    orientation /= np.linalg.norm(orientation, axis=1, keepdims=True)
    orientation[::5] *= 1.003  # hand-typed: normalised as for one body
    times = np.linspace(0.0, 200.0, 23)
    omega, q = propagate_batch(inertia, omega0, orientation, times)
    for i in range(len(inertia)):
        alone = propagate(inertia[i], omega0[i], orientation[i], times)
        np.testing.assert_array_equal(omega[i], alone[0], err_msg=f'body {i}')
        np.testing.assert_array_equal(q[i], alone[1], err_msg=f'body {i}')


def test_a_quaternion_too_far_from_unit_names_its_body():
    with pytest.raises(ValueError, match=r'body 1: orientation: expected a unit quaternion'):
        propagate_batch(
            [[1, 2, 3]] * 2, [[0.1, 0.2, 1.0]] * 2, [[0, 0, 0, 1], [0, 0, 0, 1.2]], [0.0, 1.0]
        )


def test_no_body_and_no_time_give_empty_arrays():
    omega, q = propagate_batch(np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 4)), [0.0, 1.0])
    assert omega.shape == (0, 2, 3) and q.shape == (0, 2, 4)
    omega, q = propagate_batch([[1, 2, 3]], [[0.1, 0.2, 1.0]], [[0, 0, 0, 1]], [])
    assert omega.shape == (1, 0, 3) and q.shape == (1, 0, 4)
