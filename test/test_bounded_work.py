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
Bounded work everywhere.

What the node refuses, the API and the offline tools refuse too, quickly and in our words (found by
fuzzing scenes: integrations that ran forever, overflows, scipy's messages reaching the user);
torquefree_bag stops on the first signal whatever it is computing.
"""

import os
from pathlib import Path
import resource
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from torquefree_ros.core.compiled import motion_kernels
from torquefree_ros.core.numerics import kernels
from torquefree_ros.core.propagators import MAX_STEPS_PER_SAMPLE, StepBudgetExceeded, StepTooSmall
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

BIN = Path(sys.prefix) / 'bin'
TIMEOUT = 60  # s, for a console script (its start-up re-executes the interpreter once)


def _scene(omega, effects, orientation=(0.0, 0.0, 0.0, 1.0)):
    return {
        'body': {'inertia': [3.0, 2.0, 1.5]},
        'initial': {'angular_velocity': omega, 'orientation': list(orientation)},
        'effects': effects,
    }


# (scene, the error, words of its message): each was a hang or a foreign message before; a small
# torque beside each rotor makes the scene no free gyrostat, so that auto integrates it (a rotor
# alone is the exact gyrostat, along a principal axis or oblique)
NUDGE = {'external_torque': {'torque': [0.0, 0.0, 1e-3]}}
HOSTILE = {
    'a rotor scene spinning at 1e29 rad/s': (
        _scene([1.2e29, 0.2, 1.0], [{'rotor': {'momentum': 1.0, 'axis': [0, 0.6, 0.8]}}, NUDGE]),
        StepBudgetExceeded,
        f'needs more than {MAX_STEPS_PER_SAMPLE:,} steps',
    ),
    'a torque of 1e300': (
        _scene([0.1, 0.2, 0.3], [{'external_torque': {'torque': [1e300, 0, 0]}}]),
        StepTooSmall,
        'too fast or too stiff for float64 steps, or has overflowed',
    ),
    'a rotor momentum of 1e30': (
        _scene([0.1, 0.2, 0.3], [{'rotor': {'momentum': 1e30, 'axis': [0.6, 0.8, 0]}}, NUDGE]),
        RuntimeError,
        'too stiff for an explicit integrator',
    ),
    'a damping of 1e9': (
        _scene([0.1, 0.2, 0.3], [{'damper': {'inertia': 0.1, 'damping': 1e9}}]),
        RuntimeError,
        'too stiff for an explicit integrator',
    ),
}


def _refusal(propagator):
    """
    Evaluate ``propagator`` at 100 Hz for 10 s; return its refusal and the time its solver reached.

    numpy's default handling of float errors, as a user has it (the reference path's stages
    overflow).
    """
    with np.errstate(all='ignore'), pytest.raises(RuntimeError) as raised:
        propagator(np.arange(0.0, 10.0, 0.01))
    if propagator.compiled:
        reached = float(propagator._kernel.bodies.solvers[0, motion_kernels.T])
    else:
        reached = float(propagator._solver.t)
    return raised.value, reached


@pytest.mark.parametrize('case', HOSTILE)
def test_hostile_scenes_end_quickly_in_our_words_through_the_api(
    case, integrator_path, monkeypatch
):
    """
    Hostile scenes end within a sample's step budget, counted, in our words, on both paths.

    The reference path's work is counted: the calls of our right-hand side, which scipy's DOP853
    makes (12 a step, a few more for the initial step and the dense output). The compiled path's
    steps are not visible from Python; it takes the same steps (the contract), so it must stop
    with the very refusal of the reference path, counted beside it, at the same simulated time.
    """
    data, error, words = HOSTILE[case]
    with monkeypatch.context() as reference_only:
        reference_only.setattr(kernels, 'ENABLED', False)
        reference = scene_from_mapping(data).propagator()
    assert not reference.compiled
    calls = [0]
    rhs = reference._rhs

    def counted(t, y):
        calls[0] += 1
        return rhs(t, y)

    reference._rhs = counted
    expected, expected_reached = _refusal(reference)
    assert isinstance(expected, error) and words in str(expected), str(expected)
    # the refusal came through the counted right-hand side (the counter cannot be vacuous), and
    # within one sample's budget of steps (the 1e29 rad/s rotor: 120 002 calls)
    assert 0 < calls[0] <= 16 * (MAX_STEPS_PER_SAMPLE + 1), calls[0]
    # scipy's own words never reach the user
    assert 'spacing between numbers' not in str(expected)
    if integrator_path == 'compiled':
        propagator = scene_from_mapping(data).propagator()
        assert propagator.compiled
        refused, reached = _refusal(propagator)
        assert type(refused) is type(expected) and str(refused) == str(expected), str(refused)
        # the same steps, their rounding aside: 1e-9 relative after the rotor's 10 001 steps is
        # well above their rounding (about 4e-12 observed) and far below one step (1e-4 of them)
        assert reached == pytest.approx(expected_reached, rel=1e-9, abs=0.0)


@pytest.mark.parametrize('mean_motion', [1e308, 1e200])
def test_an_effect_parameter_that_overflows_is_refused_at_load_with_its_path(mean_motion):
    data = _scene(
        [0.1, 0.2, 0.3], [{'imu': {}}, {'gravity_gradient': {'mean_motion': mean_motion}}]
    )
    with pytest.raises(
        SceneError,
        match=r"effects\[1\]\.gravity_gradient: its torque or its own state's rate "
        r'overflows float64 at the initial state',
    ):
        scene_from_mapping(data)


def test_an_override_that_makes_an_effect_overflow_is_refused_when_the_propagator_is_built():
    """
    An override that makes an effect overflow is refused when the propagator is built.

    The node's overrides (inertia, angular_velocity) reach the propagator without a scene load.
    """
    # the local vertical off every principal axis
    tilted = (0.2, 0.3, 0.1, float(np.sqrt(1 - 0.14)))
    scene = scene_from_mapping(
        _scene([0.1, 0.2, 0.3], [{'gravity_gradient': {'mean_motion': 1e150}}], tilted)
    )
    # 3 n^2 I: 3e300 N m with the scene's body; the override's 1e10 kg m^2 takes it past 1.8e308
    with pytest.raises(
        ValueError, match=r'^effects: gravity_gradient\(mean_motion=1e\+150.*overflows float64'
    ):
        scene.propagator(inertia=[3e10, 2e10, 1.5e10])


def test_the_bag_tool_ends_on_a_refused_sample_with_a_complete_bag(tmp_path):
    from torquefree_ros.bag import BagReader

    path = tmp_path / 'rotor.yaml'
    path.write_text(
        'body: {inertia: [3.0, 2.0, 1.5]}\ninitial: {angular_velocity: [1.2e29, 0.2, 1.0]}\n'
        'effects:\n  - rotor: {momentum: 1.0, axis: [0, 0.6, 0.8]}\n'
        '  - external_torque: {torque: [0, 0, 1.0e-3]}\n'
    )
    result = subprocess.run(
        [
            str(BIN / 'torquefree_bag'),
            str(path),
            '--duration',
            '10',
            '--rate',
            '100',
            '--output',
            str(tmp_path / 'bag'),
        ],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert result.returncode == 1 and 'Traceback' not in result.stderr, result.stderr
    assert f'needs more than {MAX_STEPS_PER_SAMPLE:,} steps' in result.stderr
    assert 'is a complete bag of the samples before it' in result.stderr
    reader = BagReader(tmp_path / 'bag')
    # sample 0, the initial state, and nothing after
    assert reader.complete and reader.message_count == 2


def _cpu_seconds(pid: int) -> float:
    """Return the CPU time (user + system) process ``pid`` has used so far, from /proc."""
    with open(f'/proc/{pid}/stat') as stat:
        # after the command name in parentheses: state is field 3, utime 14, stime 15 (proc(5))
        fields = stat.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def _children_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _wait_for(condition, process, what: str) -> None:
    """
    Poll ``condition`` until it holds; fail if the process ends first, or after TIMEOUT.

    The timeout only keeps a broken run from hanging the suite: nothing is decided by it.
    """
    deadline = time.monotonic() + TIMEOUT
    while not condition():
        assert process.poll() is None, f'the tool ended before {what}: {process.communicate()}'
        assert time.monotonic() < deadline, f'no {what} within {TIMEOUT} s'
        time.sleep(0.02)


# CPU time of one sample of explorer1 at 0.1 Hz by rk4 on the reference path: 10 000 Python steps,
# about 0.4 s here (0.5 s with room)
SAMPLE_CPU = 0.5


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGINT], ids=['SIGTERM', 'SIGINT'])
def test_the_bag_tool_stops_on_the_first_signal_even_when_a_sample_takes_long(tmp_path, sig):
    """
    The bag tool stops within about a sample of the first signal, even at 0.4 s a sample.

    The reference path's rk4 at 0.1 Hz: each sample is 10 000 Python steps (~0.4 s of CPU); blocks
    start at one sample and grow only while fast, so the first signal is seen within about a
    sample. The work after the signal is the tool's CPU time, which a busy machine does not
    stretch: the signal goes out once the bag exists (the tool then catches signals) and the tool
    has spent a sample's CPU time in the work.
    """
    from torquefree_ros.bag import BagReader

    children_before = _children_cpu_seconds()
    process = subprocess.Popen(
        [
            str(BIN / 'torquefree_bag'),
            'explorer1',
            '--propagator',
            'rk4',
            '--duration',
            '1e5',
            '--rate',
            '0.1',
            '--output',
            'slow',
        ],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, 'TORQUEFREE_ROS_KERNELS': 'numpy'},
    )
    try:
        _wait_for(lambda: any(tmp_path.rglob('*.mcap')), process, 'the bag file')
        opened = _cpu_seconds(process.pid)
        _wait_for(
            lambda: _cpu_seconds(process.pid) >= opened + SAMPLE_CPU, process, 'a sample of work'
        )
        signalled = _cpu_seconds(process.pid)
        process.send_signal(sig)
        _, err = process.communicate(timeout=TIMEOUT)
    finally:
        if process.poll() is None:  # a failed wait: leave no process behind
            process.kill()
            process.communicate()
    # the tool's whole CPU time, reaped by communicate (the only child this test waits for)
    after_signal = _children_cpu_seconds() - children_before - signalled
    assert process.returncode == 130 and 'Traceback' not in err, err
    # the rest of a sample or two and closing the bag (20 samples' time: room for coverage's
    # tracing), not a block of thousands of samples
    assert after_signal < 20 * SAMPLE_CPU, after_signal
    reader = BagReader(tmp_path / 'slow')
    assert reader.complete and reader.message_count >= 2
