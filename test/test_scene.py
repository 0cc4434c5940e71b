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

"""Scene files: the built-in default, and errors naming the file, the field path and the reason."""

from fractions import Fraction
from pathlib import Path
import sys

import numpy as np
import pytest
from torquefree_ros.core.propagators import make_propagator
from torquefree_ros.core.scene.loader import (
    default_scene,
    load_scene,
    scene_from_mapping,
    SceneError,
)

REPO = Path(__file__).resolve().parents[1]


def test_the_default_scene_file_is_the_built_in_default():
    scene = load_scene(REPO / 'torquefree_ros' / 'scenes' / 'default.yaml')
    built_in = default_scene()
    assert (
        scene.inertia,
        scene.angular_velocity,
        scene.orientation,
        scene.effects,
        scene.description,
    ) == (
        built_in.inertia,
        built_in.angular_velocity,
        built_in.orientation,
        built_in.effects,
        built_in.description,
    )
    assert built_in.torque_free


def test_a_minimal_scene_from_the_contract_loads(tmp_path):
    path = tmp_path / 's.yaml'
    path.write_text(
        'body:\n  inertia: [3, 2, 1]\ninitial:\n  angular_velocity: [0.001, 1.0, 0.001]\n'
        '  orientation: [0.0, 0.0, 0.0, 1.0]\neffects: []\n'
    )
    scene = load_scene(path)
    assert scene.inertia == (3.0, 2.0, 1.0) and scene.angular_velocity == (0.001, 1.0, 0.001)


@pytest.mark.parametrize(
    'text, where, reason',
    [
        ('body: {inertia: [3, 2, 1]}\n', 'initial', 'missing'),
        (
            'body: {inertia: [3, 2, 1]}\ninital: {angular_velocity: [0, 0, 1]}\n',
            'inital',
            "did you mean 'initial'",
        ),
        (
            'body: {inertia: [1, 1, 5]}\ninitial: {angular_velocity: [0, 0, 1]}\n',
            'body.inertia',
            'triangle inequality',
        ),
        (
            'body: {inertia: [3, 2]}\ninitial: {angular_velocity: [0, 0, 1]}\n',
            'body.inertia',
            '3 or 6',
        ),
        (
            'body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, .nan, 1]}\n',
            'initial.angular_velocity',
            'finite',
        ),
        (
            'body: {inertia: [3, 2, 1]}\n'
            'initial: {angular_velocity: [0, 0, 1], orientation: [0, 0, 0, 0]}\n',
            'initial.orientation',
            'zero quaternion',
        ),
        (
            "body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: 'fast'}\n",
            'initial.angular_velocity',
            'list of 3 numbers',
        ),
        (
            'body: {inertia: [3, 2, 1], mass: 2}\ninitial: {angular_velocity: [0, 0, 1]}\n',
            'body.mass',
            'unknown key',
        ),
        (
            'body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1]}\n'
            'effects: [{warp_drive: {}}]\n',
            'effects[0]',
            "unknown effect 'warp_drive'",
        ),
        (
            'body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1]}\n'
            'effects: {damper: {}}\n',
            'effects',
            'expected a list',
        ),
        ('[1, 2, 3]\n', '(top level)', 'expected a mapping'),
    ],
)
def test_bad_scenes_name_the_file_the_field_and_the_reason(tmp_path, text, where, reason):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(SceneError) as error:
        load_scene(path)
    message = str(error.value)
    assert message.startswith(f'{path}: {where}'), message
    assert reason in message, message


@pytest.mark.parametrize(
    'text, line, column, problem',
    [
        (
            'body: {inertia: [3, 2, 1]}\ninitial:\n  angular_velocity: [0, 0, 1\n',
            4,
            1,
            "expected ',' or ']'",
        ),
        ('body: {inertia: [3, 2, 1]}\n\tinitial: {}\n', 2, 1, "found character '\\t'"),
    ],
)
def test_yaml_syntax_errors_name_the_file_line_and_column(tmp_path, text, line, column, problem):
    path = tmp_path / 'typed.yaml'
    path.write_text(text)
    with pytest.raises(SceneError) as error:
        load_scene(path)
    message = str(error.value)
    assert message.startswith(f'{path}:{line}:{column}: not valid YAML: '), message
    assert problem in message and '<unicode string>' not in message, message


HAND_TYPED = [0.2, 0.1, -0.3, 0.927]  # |q| = 0.99966, |q|^2 - 1 = -6.7e-4: four typed digits


def test_a_hand_typed_orientation_is_normalised_in_scenes_and_the_api(tmp_path):
    from torquefree_ros import propagate

    path = tmp_path / 'typed.yaml'
    path.write_text(
        'body: {inertia: [3, 2, 1]}\n'
        f'initial: {{angular_velocity: [0, 0, 1], orientation: {HAND_TYPED}}}\n'
    )
    expected = np.array(HAND_TYPED) / np.linalg.norm(HAND_TYPED)
    np.testing.assert_allclose(load_scene(path).orientation, expected, rtol=0, atol=2e-16)
    _, q = propagate([3, 2, 1], [0, 0, 1], HAND_TYPED, [0.0])
    np.testing.assert_allclose(q[0], expected, rtol=0, atol=2e-16)


def test_an_orientation_unit_to_rounding_is_used_bit_for_bit():
    """
    An orientation of unit norm to rounding is used bit for bit.

    The decision for "the initial state exactly": an input whose norm is 1 to float64 rounding
    (here |q| may compute as 1 - 1 ulp) is not divided by its norm, so sample 0 equals the input.
    """
    from torquefree_ros import propagate
    from torquefree_ros.core.checks.validation import unit_quaternion

    for angle in np.linspace(0.0, 6.0, 61):
        q = [0.0, 0.0, float(np.sin(angle)), float(np.cos(angle))]
        assert unit_quaternion(q).tolist() == q
        _, q_out = propagate([1, 2, 3], [1e-3, 1.0, 2e-3], q, [0.0])
        assert q_out[0].tolist() == q


@pytest.mark.parametrize(
    'orientation, message',
    [
        (
            [0.0, 0.0, 0.0, 1.006],
            r'got norm 1.006 \(allowed: \|norm\^2 - 1\| <= 0.01, as tf2\); if \[0, 0, 0, 1\]',
        ),
        (
            [1.0, 1.0, 0.0, 0.0],
            r'got norm 1.41421 .* if \[0.707107, 0.707107, 0, 0\] is the rotation you mean',
        ),
    ],
)
def test_an_orientation_beyond_tf2s_tolerance_is_refused_with_the_normalised_value(
    tmp_path, orientation, message
):
    path = tmp_path / 'far.yaml'
    path.write_text(
        'body: {inertia: [3, 2, 1]}\n'
        f'initial: {{angular_velocity: [0, 0, 1], orientation: {orientation}}}\n'
    )
    with pytest.raises(
        SceneError, match=f'^{path}: initial.orientation: expected a unit quaternion.*' + message
    ):
        load_scene(path)


def test_a_missing_scene_file_names_the_path():
    with pytest.raises(SceneError, match=r"^scene: cannot read '/no/such/scene.yaml'"):
        load_scene('/no/such/scene.yaml')


# -- bodies from parts ----------------------------------------------------------------------------
def parts_scene(parts):
    return scene_from_mapping(
        {'body': {'parts': parts}, 'initial': {'angular_velocity': [0.1, 0.2, 0.3]}}
    )


def test_two_boxes_combine_by_the_parallel_axis_theorem():
    """
    Two boxes combine by the parallel axis theorem.

    Hand computation: centre of mass (0, 0, 0.1); own inertias m (b^2 + c^2) / 12 ...; offsets
    dA = (0.5, 0, -0.1), dB = (-1, 0, 0.2) add m (|d|^2 1 - d d^T).
    """
    scene = parts_scene(
        [
            {'box': {'mass': 2.0, 'size': [1.0, 0.5, 0.2], 'position': [0.5, 0.0, 0.0]}},
            {'box': {'mass': 1.0, 'size': [0.4, 0.4, 0.4], 'position': [-1.0, 0.0, 0.3]}},
        ]
    )
    assert scene.mass == 3.0
    np.testing.assert_allclose(scene.center_of_mass, [0.0, 0.0, 0.1], atol=1e-15)
    np.testing.assert_allclose(
        scene.inertia, [0.135, 1.76, 1.735, 0.0, 0.3, 0.0], rtol=1e-13, atol=1e-15
    )


def test_part_orientation_rotates_its_inertia_and_shapes_have_their_textbook_moments():
    turned = parts_scene(
        [
            {
                'box': {
                    'mass': 3.0,
                    'size': [1.0, 2.0, 3.0],
                    'orientation': [0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5)],  # 90 deg about z
                }
            }
        ]
    )
    plain = parts_scene([{'box': {'mass': 3.0, 'size': [2.0, 1.0, 3.0]}}])
    np.testing.assert_allclose(turned.inertia, plain.inertia, atol=1e-14)
    cylinder = parts_scene([{'cylinder': {'mass': 2.0, 'radius': 0.5, 'length': 3.0}}])
    np.testing.assert_allclose(
        cylinder.inertia[:3], [2 * (3 * 0.25 + 9) / 12] * 2 + [0.25], rtol=1e-15
    )
    sphere = parts_scene(
        [
            {'sphere': {'mass': 5.0, 'radius': 2.0}},
            {'sphere': {'mass': 3.0, 'radius': 1.0, 'hollow': True}},
        ]
    )
    np.testing.assert_allclose(sphere.inertia[:3], [0.4 * 5 * 4 + 2 / 3 * 3] * 3, rtol=1e-15)
    masses = parts_scene(
        [
            {'point_mass': {'mass': 1.0, 'position': p}}
            for p in ([1, 0, 0], [-1, 0, 0], [0, 2, 0], [0, -2, 0], [0, 0, 1], [0, 0, -1])
        ]
    )
    np.testing.assert_allclose(masses.inertia, [10.0, 4.0, 10.0, 0.0, 0.0, 0.0], atol=1e-15)


@pytest.mark.parametrize(
    'body, where, reason',
    [
        ({'parts': []}, 'body.parts', 'at least 1'),
        ({'parts': [{'box': {'mass': 1.0}}]}, 'body.parts[0].box.size', 'missing'),
        (
            {'parts': [{'box': {'mass': -1.0, 'size': [1, 1, 1]}}]},
            'body.parts[0].box.mass',
            'must be > 0',
        ),
        ({'parts': [{'cube': {'mass': 1.0}}]}, 'body.parts[0]', "unknown part 'cube'"),
        (
            {'parts': [{'sphere': {'mass': 1.0, 'radius': 1.0, 'hollw': True}}]},
            'body.parts[0].sphere.hollw',
            "did you mean 'hollow'",
        ),
        (
            {
                'parts': [
                    {'point_mass': {'mass': 1.0, 'position': [1, 0, 0]}},
                    {'point_mass': {'mass': 1.0, 'position': [-1, 0, 0]}},
                ]
            },
            'body.parts',
            'positive',
        ),
        (
            {'inertia': [3, 2, 1], 'parts': [{'sphere': {'mass': 1, 'radius': 1}}]},
            'body',
            'not both',
        ),
    ],
)
def test_bad_bodies_name_the_field(body, where, reason):
    with pytest.raises(SceneError) as error:
        scene_from_mapping(
            {'body': body, 'initial': {'angular_velocity': [0, 0, 1]}}, source='s.yaml'
        )
    assert str(error.value).startswith(f's.yaml: {where}: '), str(error.value)
    assert reason in str(error.value)


WHEEL_X = {
    'name': 'rw1', 'axis': [1, 0, 0], 'spin_inertia': 0.01, 'max_torque': 0.02, 'max_speed': 600.0
}
WHEEL_Y = {**WHEEL_X, 'name': 'rw2', 'axis': [0, 1, 0]}


@pytest.mark.parametrize(
    'effects, where, reason',
    [
        (
            [
                {'damper': {'inertia': 0.1, 'damping': 0.1}},
                {'external_torque': {'torque': [0, 1]}},
            ],
            'effects[1].external_torque.torque',
            'expected 3 numbers',
        ),
        (
            [{'external_torque': {'torqe': [0, 0, 1]}}],
            'effects[0].external_torque.torqe',
            "did you mean 'torque'",
        ),
        (
            [{'external_torque': {'torque': [0, 0, 1], 'frame': 'world'}}],
            'effects[0].external_torque.frame',
            'expected one of body, inertial',
        ),
        ([{'dampr': {}}], 'effects[0]', "did you mean 'damper'"),
        ([{'damper': {'inertia': 0.1}}], 'effects[0].damper.damping', 'missing'),
        (
            [{'gravity_gradient': {'mean_motion': 0.001, 'radius': 7e6}}],
            'effects[0].gravity_gradient',
            'not both',
        ),
        ([{'gravity_gradient': {}}], 'effects[0].gravity_gradient.radius', 'missing'),
        (
            [{'rotor': {'momentum': 1.0, 'axis': [0, 0, 0]}}],
            'effects[0].rotor.axis',
            'zero vector',
        ),
        ([{'imu': {'seed': -1}}], 'effects[0].imu.seed', 'must lie in'),
        (
            [{'imu': {'gyro_noise_density': 'high'}}],
            'effects[0].imu.gyro_noise_density',
            'finite number',
        ),
        ([{'imu': {}}, {'imu': {}}], 'effects[1].imu.topic', 'already the topic of effects[0]'),
        (  # wheels in two modes: each array's commands name only its own wheels
            [
                {'reaction_wheels': {'mode': 'torque', 'wheels': [WHEEL_X]}},
                {'reaction_wheels': {'mode': 'speed', 'wheels': [WHEEL_Y]}},
            ],
            'effects[1].reaction_wheels.topic',
            'already the topic of effects[0]',
        ),
        (
            [
                {'torque_command': {'topic': 'ctrl'}},
                {'imu': {'topic': 'ctrl'}},
            ],
            'effects[1].imu.topic',
            'already the topic of effects[0]',
        ),
        (
            [{'torque_command': {'topic': '/diagnostics'}}],
            'effects[0].torque_command.topic',
            "simulator's own",
        ),
        (
            [{'euler_angles': {'topic': 'attitude'}}],
            'effects[0].euler_angles.topic',
            "simulator's own",
        ),
        (
            [{'euler_angles': {'topic': 'rpy angles'}}],
            'effects[0].euler_angles.topic',
            'ROS topic name',
        ),
        (
            [{'damper': {'inertia': 0.1, 'damping': 0.1}, 'rotor': {}}],
            'effects[0]',
            'one-key mapping',
        ),
    ],
)
def test_bad_effects_name_the_path_and_the_reason(effects, where, reason):
    with pytest.raises(SceneError) as error:
        scene_from_mapping(
            {
                'body': {'inertia': [3, 2, 1]},
                'initial': {'angular_velocity': [0, 0, 1]},
                'effects': effects,
            },
            source='s.yaml',
        )
    assert str(error.value).startswith(f's.yaml: {where}: '), str(error.value)
    assert reason in str(error.value)


def test_arrays_that_take_no_commands_share_the_default_topic():
    """Only commanded arrays claim their topic: scheduled ones take no commands on it."""
    scene = scene_from_mapping(
        {
            'body': {'inertia': [3, 2, 1]},
            'initial': {'angular_velocity': [0, 0, 1]},
            'effects': [
                {'reaction_wheels': {'wheels': [WHEEL_X]}},
                {'reaction_wheels': {'wheels': [WHEEL_Y]}},
                {'reaction_wheels': {'mode': 'torque', 'wheels': [{**WHEEL_X, 'name': 'rw3'}]}},
            ],
        }
    )
    assert [effect.values['topic'] for effect in scene.effects] == ['wheel_command'] * 3


def test_yaml_1_2_numbers_are_numbers(tmp_path):
    """
    Scene files read YAML 1.2 numbers as numbers.

    PyYAML reads 3.986e14 and 1e-3 as strings (YAML 1.1); scene files read them as numbers.
    """
    path = tmp_path / 's.yaml'
    path.write_text(
        'body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [1e-3, 0, 2]}\n'
        'effects: [{gravity_gradient: {radius: 7e6, gravitational_parameter: 3.986e14}}]\n'
        'accuracy: 1e-9\n'
    )
    scene = load_scene(path)
    assert scene.angular_velocity == (0.001, 0.0, 2.0) and scene.accuracy == 1e-9
    assert scene.effects[0].mean_motion == pytest.approx(np.sqrt(3.986e14 / 7e6**3), rel=1e-15)


# -- initial states float64 cannot hold -----------------------------------------------------------
def exact_scale(moments, rates) -> Fraction:
    """Return ``|H|^2 I_max^2`` in exact rational arithmetic, for a body in its principal frame."""
    moments = [Fraction(m) for m in moments]
    momentum = [m * Fraction(w) for m, w in zip(moments, rates)]
    return sum(h * h for h in momentum) * max(moments) ** 2


FLOAT64_MAX = Fraction(sys.float_info.max)

OVERFLOWING = [
    ([3, 2, 1], [1e154, 0, 0]),  # a fuzzed file's rate: |H|^2 I_max^2 = 8.1e309
    ([3, 2, 1], [0, 0, 1e154]),  # about the minor axis: 9e308, just past 1.8e308
    ([3, 2, 1], [1e308, 0, 0]),  # |H| = 3e308 itself overflows
    ([3, 2, 1], [1e200, 1e200, 1e200]),  # and the energy w.I.w = 6e400
    ([1e100, 1e100, 1e100], [1, 0, 0]),  # the largest inertia allowed, at 1 rad/s: 1e400
    ([1e100, 1e100, 1e100, 0, 0, 0], [0, 1e250, 0]),  # a tensor: |H| = 1e350
]


@pytest.mark.parametrize('inertia, rates', OVERFLOWING)
def test_an_initial_state_that_overflows_is_refused_when_the_scene_loads(tmp_path, inertia, rates):
    """
    An initial state that overflows is refused when the scene loads, as a propagator refuses it.

    Each case is far past float64's largest number in exact arithmetic (the reference); the file,
    the mapping and a scene with effects all name ``initial.angular_velocity``.
    """
    assert exact_scale(inertia[:3], rates) > FLOAT64_MAX
    path = tmp_path / 'fast.yaml'
    path.write_text(f'body: {{inertia: {inertia}}}\ninitial: {{angular_velocity: {rates}}}\n')
    with pytest.raises(SceneError) as error:
        load_scene(path)
    message = str(error.value)
    assert message.startswith(f'{path}: initial.angular_velocity: the state '), message
    assert 'overflows float64' in message, message
    damped = {
        'body': {'inertia': inertia},
        'initial': {'angular_velocity': rates},
        'effects': [{'damper': {'inertia': 0.05, 'damping': 0.01}}],
    }
    with pytest.raises(SceneError, match=r'^s\.yaml: initial\.angular_velocity: .*overflows'):
        scene_from_mapping(damped, source='s.yaml')
    with pytest.raises(ValueError, match=r'^angular_velocity: .*overflows float64'):
        make_propagator(inertia, rates, [0, 0, 0, 1])


# |H|^2 I_max^2 of [0.5, 0.1, 0.1] rad/s on [3, 2, 1] kg m^2, times 2^1018: 5.8e307, the largest
# power-of-two scale float64 holds (2^1020 times it, 2.3e308, is over 1.8e308)
SCALE = 2.0**509


def test_an_extreme_state_that_float64_holds_loads_and_moves_as_at_unit_scale(tmp_path):
    """
    An extreme state float64 holds loads, and moves as the same body at unit scale.

    Torque-free motion scales: ``w(t; s w0) = s w(s t; w0)``; a power-of-two ``s`` is exact in
    float64, so the two solutions differ by the solution's own rounding at most.
    """
    rates = [0.5, 0.1, 0.1]
    fast = [SCALE * w for w in rates]
    twice = [2 * w for w in fast]
    assert exact_scale([3, 2, 1], fast) < FLOAT64_MAX < exact_scale([3, 2, 1], twice)
    path = tmp_path / 'extreme.yaml'
    path.write_text(f'body: {{inertia: [3, 2, 1]}}\ninitial: {{angular_velocity: {fast}}}\n')
    scene = load_scene(path)
    assert scene.angular_velocity == tuple(fast)
    times = np.linspace(0.0, 20.0, 41)  # over a turn at about 0.5 rad/s (at unit scale)
    omega, q = scene.propagator()(times / SCALE)
    omega_unit, q_unit = make_propagator([3, 2, 1], rates, [0, 0, 0, 1])(times)
    # 1e-14 on rates of order 1 (rad/s at unit scale) and unit quaternions: a few rounding units
    np.testing.assert_allclose(omega / SCALE, omega_unit, rtol=0, atol=1e-14)
    np.testing.assert_allclose(q, q_unit, rtol=0, atol=1e-14)
    doubled = {'body': {'inertia': [3, 2, 1]}, 'initial': {'angular_velocity': twice}}
    with pytest.raises(SceneError, match=r'initial\.angular_velocity: .*overflows float64'):
        scene_from_mapping(doubled)
