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

"""Attitude conventions, checked against scipy's Rotation (scalar-last, Hamilton, active)."""

from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from torquefree_ros.core.frames import quaternion


# no values so small that their squares underflow (the tests raise on every float exception)
def _component(bound):
    return st.floats(-bound, bound).filter(lambda x: x == 0 or abs(x) > 1e-30)


unit = (
    arrays(np.float64, 4, elements=_component(1))
    .filter(lambda v: np.linalg.norm(v) > 0.1)
    .map(lambda v: v / np.linalg.norm(v))
)
vector = arrays(np.float64, 3, elements=_component(10))


@given(unit, unit)
def test_product_composes_rotations_like_scipy(p, q):
    expected = (Rotation.from_quat(p) * Rotation.from_quat(q)).as_matrix()
    # 1e-14: a few roundings of products of unit-size numbers
    np.testing.assert_allclose(
        quaternion.to_matrix(quaternion.multiply(p, q)), expected, atol=1e-14
    )


@given(unit, vector)
def test_matrix_maps_body_vectors_into_the_inertial_frame(q, v):
    np.testing.assert_allclose(quaternion.rotate(q, v), Rotation.from_quat(q).apply(v), atol=1e-13)


@given(unit)
def test_from_matrix_round_trips_up_to_sign(q):
    back = quaternion.from_matrix(quaternion.to_matrix(q))
    assert abs(abs(back @ q) - 1.0) < 1e-14  # the same rotation: back = q or back = -q
    assert back[3] >= 0.0
    np.testing.assert_allclose(quaternion.to_matrix(back), quaternion.to_matrix(q), atol=1e-14)


@given(vector)
def test_exp_rotation_is_scipy_rotvec(v):
    np.testing.assert_allclose(
        quaternion.to_matrix(quaternion.exp_rotation(v)),
        Rotation.from_rotvec(v).as_matrix(),
        atol=1e-14,
    )


@pytest.mark.parametrize('angle', [1e-12, 1e-8, 0.99e-4, 1.01e-4])
def test_exp_rotation_is_accurate_on_both_sides_of_the_series_switch(angle):
    q = quaternion.exp_rotation(np.array([angle, 0.0, 0.0]))
    # sin(angle/2) is correctly rounded by libm; the series must match it to an ulp or two
    assert q[0] == pytest.approx(np.sin(angle / 2), rel=3e-16)
    assert q[3] == pytest.approx(np.cos(angle / 2), rel=1e-16)


@settings(max_examples=50)
@given(unit)
def test_angle_between_ignores_sign_and_is_exact_for_tiny_angles(q):
    assert quaternion.angle_between(q, -q) < 1e-15
    tiny = quaternion.multiply(q, quaternion.exp_rotation(np.array([0.0, 3e-12, 0.0])))
    assert abs(quaternion.angle_between(q, tiny) - 3e-12) < 1e-20 + 1e-4 * 3e-12


@given(unit, unit, vector, vector)
def test_the_single_float_path_agrees_with_the_batched_one(p, q, v, u):
    """
    The single-float path agrees with the batched one.

    One quaternion or vector takes plain float arithmetic (the integrators' stages); a batch takes
    numpy's. Both give the same numbers.
    """
    np.testing.assert_allclose(
        quaternion.multiply(p, q), quaternion.multiply(p[None], q[None])[0], atol=1e-15
    )
    np.testing.assert_allclose(
        quaternion.rotate(q, v), quaternion.rotate(q[None], v[None])[0], atol=1e-13
    )
    np.testing.assert_allclose(quaternion.cross(u, v), np.cross(u, v), atol=1e-12)
    np.testing.assert_allclose(
        quaternion.exp_rotation(v), quaternion.exp_rotation(v[None])[0], atol=1e-15
    )
    np.testing.assert_allclose(
        quaternion.rotate_inverse(q, quaternion.rotate(q, v)), v, atol=1e-13
    )
    np.testing.assert_allclose(
        quaternion.rotate_inverse(q, v), Rotation.from_quat(q).inv().apply(v), atol=1e-13
    )


@given(unit, unit, arrays(np.float64, (3, 4), elements=_component(1)))
def test_product_matrix_is_the_product_on_both_sides(p, q, x):
    expected = quaternion.multiply(quaternion.multiply(p, x), q)
    np.testing.assert_allclose(x @ quaternion.product_matrix(p, q).T, expected, atol=1e-15)
