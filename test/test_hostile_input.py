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
Hostile input: malformed parameter messages, fuzzed parameter values, mutated scene files.

The parameter messages and values are sent over DDS; damaged bags are test_bag_damage.py's. Every
input gets a clear refusal (or a Scene) in bounded time and size, and the node keeps publishing.
Budgets are fixed (hypothesis ``max_examples``) so CI time is bounded.
"""

from __future__ import annotations

import os
import string
import tempfile
import time

from hostile_yaml import billion_laughs
from hypothesis import given, HealthCheck, settings
from hypothesis import strategies as st
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter as ParameterMessage
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically
from sim_harness import connected_harness
from torquefree_ros.core.scene.loader import load_scene, MAX_SCENE_BYTES, Scene, SceneError
from torquefree_ros.ros.guarded_parameters import MAX_REASON_LENGTH
from torquefree_ros.ros.parameters import SPECS

# a refusal is one line; "… (N characters)" may follow the clip
MAX_MESSAGE = MAX_REASON_LENGTH + 40
SCENE = (
    'description: fuzz\nbody:\n  inertia: [3.0, 2.0, 1.0]\n'
    'initial:\n  angular_velocity: [0.3, 0.2, 1.0]\n'
    '  orientation: [0.0, 0.0, 0.0, 1.0]\neffects:\n  - damper: {inertia: 0.05, damping: 0.01}\n'
    '  - imu: {gyro_noise_density: 1.0e-4, seed: 42}\naccuracy: 1.0e-9\n'
)


@pytest.fixture(scope='module')
def harness():
    with connected_harness(publish_rate=100.0) as h:
        yield h


def _call(harness, service_type, name, request):
    client = harness.client.create_client(
        service_type, f'{harness.node.get_fully_qualified_name()}/{name}'
    )
    try:
        harness.spin_until(client.service_is_ready, what=name)
        return harness.wait_future(client.call_async(request), name)
    finally:
        harness.client.destroy_client(client)


def _still_publishing(harness):
    last = harness.pairs()[-1][0] if harness.pairs() else None
    harness.wait_samples(3, after=last)


def _raw(name, kind, **fields):
    return ParameterMessage(name=name, value=ParameterValue(type=kind, **fields))


@pytest.mark.parametrize(
    'message, reason',
    [
        (_raw('publish_rate', 99), 'publish_rate: 99 is not a parameter type'),
        (_raw('inertia', 255), 'inertia: 255 is not a parameter type'),
        (
            _raw('x' * 300, ParameterType.PARAMETER_DOUBLE, double_value=1.0),
            'a parameter name has 1 to 256 characters',
        ),
        (
            _raw(
                'inertia',
                ParameterType.PARAMETER_DOUBLE_ARRAY,
                double_array_value=[1e308, 1e308, 1e308],
            ),
            'overflows',
        ),
        (
            _raw('inertial_frame', ParameterType.PARAMETER_STRING, string_value='w' * 1_000_000),
            'frame id',
        ),
        (
            _raw('scene', ParameterType.PARAMETER_STRING, string_value='/dev/zero'),
            'scene_directories',
        ),
        (
            _raw('scene', ParameterType.PARAMETER_STRING, string_value='/' + 's' * 256),
            'nor a file under scene_directories',
        ),
        # inside scene_directories: read, and refused for its name (ENAMETOOLONG)
        (
            _raw(
                'scene',
                ParameterType.PARAMETER_STRING,
                string_value=os.path.join(tempfile.gettempdir(), 's' * 256),
            ),
            'cannot read',
        ),
    ],
)
def test_malformed_parameter_messages_are_refused_and_the_node_keeps_publishing(
    harness, message, reason
):
    for service_type, service in (
        (SetParameters, 'set_parameters'),
        (SetParametersAtomically, 'set_parameters_atomically'),
    ):
        request = service_type.Request(parameters=[message])
        response = _call(harness, service_type, service, request)
        result = response.results[0] if service == 'set_parameters' else response.result
        assert not result.successful and reason in result.reason, result.reason
        assert len(result.reason) <= MAX_MESSAGE
    _still_publishing(harness)


def test_get_parameters_with_odd_names_answers(harness):
    names = ['', 'x' * 10_000, 'inertia', 'qos_depth']
    response = _call(harness, GetParameters, 'get_parameters', GetParameters.Request(names=names))
    # one value per name, in order: names the node does not have are not set (undeclared names are
    # allowed, so rclpy answers them), inertia is declared without a value, qos_depth (read-only)
    # is 10
    assert [value.type for value in response.values] == [ParameterType.PARAMETER_NOT_SET] * 3 + [
        ParameterType.PARAMETER_INTEGER
    ]
    assert response.values[3].integer_value == 10
    _still_publishing(harness)


_VALUE = st.one_of(
    st.builds(lambda t: ParameterValue(type=t), st.integers(0, 255)),
    st.builds(
        lambda b: ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=b), st.booleans()
    ),
    st.builds(
        lambda i: ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=i),
        st.integers(-(2**63), 2**63 - 1),
    ),
    st.builds(
        lambda d: ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=d), st.floats()
    ),
    st.builds(
        lambda s: ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=s),
        st.text(string.printable, max_size=300),
    ),
    st.builds(
        lambda a: ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=a),
        st.lists(st.floats(), max_size=8),
    ),
    st.builds(
        lambda a: ParameterValue(
            type=ParameterType.PARAMETER_INTEGER_ARRAY, integer_array_value=a
        ),
        st.lists(st.integers(-(2**63), 2**63 - 1), max_size=8),
    ),
    st.builds(
        lambda a: ParameterValue(type=ParameterType.PARAMETER_STRING_ARRAY, string_array_value=a),
        st.lists(st.text(max_size=20), max_size=4),
    ),
)
_NAME = st.one_of(
    st.sampled_from([spec.name for spec in SPECS]),
    st.text(string.ascii_letters + '_.', max_size=30),
)


@settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    names=st.lists(_NAME, min_size=1, max_size=3), values=st.lists(_VALUE, min_size=3, max_size=3)
)
def test_fuzzed_parameter_requests_never_stop_the_node(harness, names, values):
    request = SetParameters.Request(
        parameters=[ParameterMessage(name=n, value=v) for n, v in zip(names, values)]
    )
    response = _call(harness, SetParameters, 'set_parameters', request)
    assert len(response.results) == len(request.parameters)
    assert all(len(result.reason) <= MAX_MESSAGE for result in response.results)
    assert harness.node.sample_loop.running and not harness.node.sample_loop.failure
    # whatever was accepted, the node can still be reset or refuses with a reason
    harness.reset()


def test_a_real_time_factor_too_small_for_any_wait_leaves_the_node_waiting(harness):
    """
    A real_time_factor too small for any wait leaves the node waiting.

    1e-300 is in range, and puts the next sample beyond what a thread can wait for at once (it once
    stopped the sample loop with OverflowError: found by the fuzz test above).
    """
    request = SetParameters.Request(
        parameters=[_raw('real_time_factor', ParameterType.PARAMETER_DOUBLE, double_value=1e-300)]
    )
    assert _call(harness, SetParameters, 'set_parameters', request).results[0].successful
    harness.reset()
    time.sleep(0.3)
    assert harness.node.sample_loop.running and not harness.node.sample_loop.failure
    request = SetParameters.Request(
        parameters=[_raw('real_time_factor', ParameterType.PARAMETER_DOUBLE, double_value=1.0)]
    )
    assert _call(harness, SetParameters, 'set_parameters', request).results[0].successful
    harness.reset()
    _still_publishing(harness)


# -- scene files ----------------------------------------------------------------------------------


def _load(tmp_path, text: str):
    path = tmp_path / 'fuzz.yaml'
    path.write_text(text)
    # this thread's CPU time, which other processes on a busy machine do not stretch: loading is
    # single-threaded and takes milliseconds, so 5 s only fails for work that is not bounded
    started = time.thread_time()
    try:
        return load_scene(path)
    except SceneError as error:
        message = str(error)
        assert message.startswith(str(path)) or message.startswith('scene:'), message
        assert len(message) < 2000, message[:300]
        return error
    finally:
        assert time.thread_time() - started < 5.0


@pytest.mark.parametrize(
    'text, reason',
    [
        (billion_laughs(), 'too large once its aliases are expanded'),
        ('body: ' + '[' * 5000 + ']' * 5000 + '\n', 'nested too deeply'),
        (
            SCENE.replace('[3.0, 2.0, 1.0]', '[3' + '0' * 400 + ', 2, 1]'),
            'body.inertia: every entry must be finite',
        ),
        (SCENE + 'body: {inertia: [1, 2, 3]}\n', "duplicate key 'body' (first at line 2)"),
        # YAML 1.1 scalars that look like numbers but are not (PyYAML reads them as strings)
        (
            SCENE.replace('seed: 42', 'seed: 0b'),
            "effects[1].imu.seed: expected an integer, got '0b'",
        ),
        # found by hypothesis
        (SCENE.replace('seed: 42', 'seed: !!int '), 'a value cannot be read (IndexError'),
        (
            SCENE.replace('accuracy: 1.0e-9', 'accuracy: 0o99'),
            "accuracy: expected a finite number, got '0o99'",
        ),
        ('\x00\x01binary', 'not valid YAML'),
        # found by hypothesis: states that loaded, then failed when the propagator was built
        (
            SCENE.replace('[0.3, 0.2, 1.0]', '[1e154, 0, 0]'),
            'initial.angular_velocity: the state [1e+154, 0.0, 0.0] with moments',
        ),
        (
            SCENE.replace('[0.3, 0.2, 1.0]', '[0.3, 1e308, 1.0]'),
            'initial.angular_velocity: the state [0.3, 1e+308, 1.0] with moments',
        ),
    ],
)
def test_hostile_scene_files_are_refused_quickly_with_a_short_reason(tmp_path, text, reason):
    result = _load(tmp_path, text)
    assert isinstance(result, SceneError) and reason in str(result), str(result)[:300]


def test_special_and_huge_files_are_not_read(tmp_path):
    fifo = tmp_path / 'fifo.yaml'
    os.mkfifo(fifo)
    with pytest.raises(SceneError, match='is not a regular file'):
        load_scene(fifo)  # would block forever if opened for a blocking read
    with pytest.raises(SceneError, match='is not a regular file'):
        load_scene('/dev/zero')
    big = tmp_path / 'big.yaml'
    big.write_text(SCENE + '#' * MAX_SCENE_BYTES)
    with pytest.raises(SceneError, match='is larger than 1,048,576 bytes'):
        load_scene(big)


_MUTATION = st.tuples(
    st.integers(0, len(SCENE)),
    st.integers(0, 6),
    st.sampled_from(
        [
            '',
            '*',
            '&a ',
            '[',
            '{',
            ']',
            '}',
            ':',
            '-',
            ' ',
            '\n',
            '\t',
            '!!int ',
            '!!binary ',
            '1e400',
            '1e154',
            '1e308',
            '9' * 30,
            '.nan',
            '~',
            "'",
            '"',
            '? ',
            '|',
            '&b [*a, *a]',
        ]
    ),
)


@settings(
    max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(mutations=st.lists(_MUTATION, min_size=1, max_size=6))
def test_mutated_scene_files_give_a_scene_or_a_scene_error(tmp_path, mutations):
    text = SCENE
    for position, length, insert in mutations:
        position = min(position, len(text))
        text = text[:position] + insert + text[position + length:]
    result = _load(tmp_path, text)
    assert isinstance(result, (Scene, SceneError))
    if isinstance(result, Scene):
        from torquefree_ros.core.run.simulation import Simulation

        # what loads builds its propagator: load_scene refuses every state and effect that
        # overflows float64, with its field path, by the rules the propagators apply
        propagator = result.propagator()
        # and gives finite samples, or refuses them with its reason (a too-stiff scene, a run over
        # the step budget)
        try:
            block = Simulation(propagator, 10.0).samples(0, 3)
        except (ValueError, RuntimeError):
            return
        assert np.all(np.isfinite(block.omega_B)) and np.all(np.isfinite(block.q_NB))
        # unit quaternions: 1e-12 is far above the propagators' rounding (test_propagators.py)
        np.testing.assert_allclose(np.linalg.norm(block.q_NB, axis=1), 1.0, rtol=0, atol=1e-12)
        # 3 samples at 10 Hz
        np.testing.assert_array_equal(block.stamps_ns, [0, 100_000_000, 200_000_000])


def test_an_output_topic_too_long_for_dds_is_a_scene_error(tmp_path):
    path = tmp_path / 'topic.yaml'
    path.write_text(
        'body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1]}\n'
        f'effects:\n  - euler_angles: {{topic: {"t" * 300}}}\n'
    )
    with pytest.raises(
        SceneError, match=r'effects\[0\]\.euler_angles\.topic: expected a ROS topic name'
    ):
        load_scene(path)
