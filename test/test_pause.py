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
Pause and resume through the node (``~/pause``, std_srvs/SetBool), in process.

No sample while paused, the resumed samples are those of a run never paused (same indices, the
exact values), /clock held, a pause in lock-step, a pause while recording (the bag shows the gap in
time and nothing else), a reset while paused, and what /diagnostics and the answers say.

"Nothing arrives while paused" can only be shown by waiting: each such test spins the executor for
PAUSED_SPIN wall seconds (bounded; the node's own counters say nothing went out, the received
samples say nothing arrived). At real_time_factor 0 the node would publish thousands of samples in
that time, at 100 Hz thirty.
"""

from __future__ import annotations

import re
import time

import numpy as np
import pytest
from sim_harness import connected_harness, reset_epoch_ns, stamp_ns
from torquefree_ros import propagate
from torquefree_ros.core.scene.loader import default_scene

DEFAULT = default_scene()
RATE = 100.0
PERIOD = 10_000_000  # ns at RATE
PAUSED_SPIN = (
    0.3  # wall s spun while paused, to see that nothing goes out (see the module docstring)
)


def pause_client(harness):
    from std_srvs.srv import SetBool

    client = harness.client.create_client(
        SetBool, f'{harness.node.get_fully_qualified_name()}/pause'
    )
    harness.spin_until(client.service_is_ready, what='the pause service')
    return client


def call_pause(harness, client, data: bool):
    from std_srvs.srv import SetBool

    response = harness.wait_future(client.call_async(SetBool.Request(data=data)), '~/pause')
    assert response.success, response.message
    return response


def paused_at(response) -> int:
    match = re.match(r'paused at sample (\d+) \(t = ', response.message)
    assert match, response.message
    return int(match[1])


def resumed_at(response) -> int:
    match = re.match(r'resumed at sample (\d+) \(t = ', response.message)
    assert match, response.message
    return int(match[1])


def shift_ns(response) -> int:
    match = re.search(r'stamps shifted by \+(\d+)\.(\d{9}) s', response.message)
    assert match, response.message
    return int(match[1]) * 1_000_000_000 + int(match[2])


def spin_for(harness, seconds: float) -> None:
    end = time.monotonic() + seconds
    harness.spin_until(
        lambda: time.monotonic() >= end, timeout=seconds + 5.0, what='the bounded spin'
    )


def assert_exact(ks, omega, q, rate=RATE, scene=DEFAULT):
    """Values of samples ``ks`` equal the exact solution at t_k = k / rate, bit for bit."""
    w_ref, q_ref = propagate(
        scene.inertia, scene.angular_velocity, scene.orientation, np.asarray(ks) / rate
    )
    np.testing.assert_array_equal(np.asarray(omega), w_ref)
    np.testing.assert_array_equal(np.asarray(q), q_ref)


def our_diagnostics(harness, key: str, value: str):
    name = harness.node.get_fully_qualified_name()
    for array in reversed(harness.diagnostics):
        status = array.status[0]
        values = {v.key: v.value for v in status.values}
        if status.hardware_id == name and values.get(key) == value:
            return status, values
    return None


# -- a clock of our own: the clock holds, stamps continue without a gap ---------------------------


@pytest.mark.parametrize('factor', [0.0, 2.0], ids=['as_fast_as_possible', 'twice_real_time'])
def test_nothing_goes_out_while_paused_the_clock_holds_and_the_run_continues(factor):
    # started paced and connected, then reset into the factor: discovery is slow while a node
    # floods
    with connected_harness(publish_rate=RATE, real_time_factor=2.0, qos_depth=10000) as harness:
        client = pause_client(harness)
        loop = harness.node.sample_loop
        assert harness.set_parameters(real_time_factor=factor)[0].successful
        response = harness.reset()
        assert response.success, response.message
        epoch = reset_epoch_ns(response)
        harness.wait_samples(30, after=epoch - 1)
        response = call_pause(harness, client, True)
        k = paused_at(response)
        # samples 0 .. k - 1 of the run are out, the clock holds at k - 1's stamp
        held = epoch + (k - 1) * PERIOD
        assert (
            loop.last.simulation is loop.simulation
            and loop.last.index == k - 1
            and loop.last.stamp_ns == held
        )
        assert f'/clock holds at {held // 10**9}.{held % 10**9:09d} s' in response.message, (
            response.message
        )
        assert 'stamps continue where they stopped, with no gap' in response.message
        published = loop.published
        spin_for(harness, PAUSED_SPIN)
        # what went out before the pause has arrived (as fast as possible, a backlog can remain),
        # and the held clock, after sample k - 1's own clock message
        harness.spin_until(
            lambda: (
                max(harness.omega) >= held
                and max(harness.q) >= held
                and harness.clock.count(held) >= 2
            ),
            what='sample k - 1 and the held clock',
        )
        # /diagnostics says so (a wait on a condition: it reports once a second)
        harness.spin_until(
            lambda: our_diagnostics(harness, 'paused', 'true'), what='paused in /diagnostics'
        )
        status, values = our_diagnostics(harness, 'paused', 'true')
        assert status.message.startswith(f'paused at sample {k} (t = ') and values[
            'paused_at'
        ].startswith(f'sample {k} ')
        assert loop.published == published and loop.last.index == k - 1  # nothing went out
        assert max(harness.omega) == max(harness.q) == held  # nothing arrived past the pause
        assert max(harness.clock) == held  # the held clock only (10 Hz)
        again = call_pause(harness, client, True)
        assert (
            again.message.startswith(f'already paused at sample {k} (t = ')
            and 'nothing changed' in again.message
        )

        response = call_pause(harness, client, False)
        resumed = time.monotonic()
        assert resumed_at(response) == k and 'with no gap' in response.message
        harness.spin_until(lambda: loop.last.index >= k + 40, what='samples after resuming')
        # the node's own record: the same run, its clock continuing from the held value
        assert loop.last.stamp_ns == epoch + loop.last.index * PERIOD
        if factor:
            # paced: the pacing moved on with the pause, so samples k .. k + 40 take 0.2 s at 200 a
            # second, not a burst of the paused time's worth (0.3 s * 200 = 60 samples due at
            # once); a lower bound, which load only makes easier
            assert time.monotonic() - resumed >= 0.1
        assert 'not paused' in call_pause(harness, client, False).message
        if factor == 0.0:
            # as fast as possible, a subscriber may lose samples (keep-last): check those that came
            received = sorted(s for s in harness.omega.keys() & harness.q.keys() if s > held)[:200]
            assert received, 'no sample arrived after resuming'
            ks, off_grid = np.divmod(np.array(received) - epoch, PERIOD)
            assert not np.any(off_grid)  # on the grid epoch + k / rate: no gap in the stamps
            assert_exact(
                ks, [harness.omega[s] for s in received], [harness.q[s] for s in received]
            )
            return
        last = epoch + (k + 39) * PERIOD
        harness.spin_until(
            lambda: last in harness.omega and last in harness.q and last in harness.clock,
            what='sample k + 39 and its clock',
        )
        pairs = [p for p in harness.pairs() if epoch <= p[0] <= last]
        stamps = np.array([s for s, _, _ in pairs])
        # contiguous in index from sample 0 and on the grid epoch + k / rate across the pause: no
        # gap, no repeat
        np.testing.assert_array_equal(stamps, epoch + np.arange(k + 40) * PERIOD)
        assert_exact(np.arange(k + 40), [w for _, w, _ in pairs], [q for _, _, q in pairs])
        # /clock: every sample's stamp once, in order, the held value repeated in between
        clock = np.array(harness.clock)
        clock = clock[(clock >= epoch) & (clock <= last)]
        assert np.all(np.diff(clock) >= 0)
        changes = np.concatenate([[True], np.diff(clock) != 0])
        np.testing.assert_array_equal(clock[changes], stamps)
        # the sample's own clock message and at least one held
        assert np.count_nonzero(clock == held) >= 2


# -- wall-clock stamps: the epoch moves on by the time paused -------------------------------------


def test_wall_clock_stamps_move_on_by_the_time_paused_and_the_values_are_the_unpaused_run(
    tmp_path,
):
    with connected_harness(publish_rate=RATE, publish_clock=True) as harness:
        client = pause_client(harness)
        loop = harness.node.sample_loop
        response = harness.reset()
        assert response.success, response.message
        epoch = reset_epoch_ns(response)
        harness.wait_samples(20, after=epoch - 1)
        pause_asked = time.monotonic()
        response = call_pause(harness, client, True)
        k = paused_at(response)
        assert "the run's epoch moves on by the time paused" in response.message, response.message
        held = epoch + (k - 1) * PERIOD
        assert loop.last.stamp_ns == held
        spin_for(harness, PAUSED_SPIN)
        # nothing went out, nothing arrived
        assert loop.last.stamp_ns == held and max(harness.omega) == held
        # /clock held at the last stamp: again and again after the last sample's own message
        harness.spin_until(lambda: harness.clock.count(held) >= 2, what='the held clock')
        assert max(harness.clock) == held
        response = call_pause(harness, client, False)
        paused_for = time.monotonic() - pause_asked
        assert resumed_at(response) == k
        shift = shift_ns(response)
        # the time paused (monotonic): at least the spin, at most from asking to pause to the
        # answer to resume
        assert PAUSED_SPIN * 1e9 <= shift <= paused_for * 1e9
        count = k + 20
        stamps_expected = [epoch + j * PERIOD + (shift if j >= k else 0) for j in range(count)]
        harness.spin_until(
            lambda: (
                all(s in harness.omega and s in harness.q for s in stamps_expected)
                and stamps_expected[-1] in harness.clock
            ),
            what="samples 0 .. k + 19 at the rule's stamps",
        )
        run = [p for p in harness.pairs() if epoch <= p[0] <= stamps_expected[-1]]
        # exactly those stamps: before the pause epoch + t_k, after it epoch + shift + t_k
        assert [s for s, _, _ in run] == stamps_expected
        assert_exact(np.arange(count), [w for _, w, _ in run], [q for _, _, q in run])
        # no stamp goes backwards, and the gap is where the pause was
        gaps = np.diff(stamps_expected)
        assert np.all(gaps > 0) and np.flatnonzero(gaps != PERIOD).tolist() == [k - 1]
        assert gaps[k - 1] == PERIOD + shift
        # publish_clock: /clock carries the samples' stamps, held during the pause
        clock = np.array(harness.clock)
        clock = clock[(clock >= epoch) & (clock <= stamps_expected[-1])]
        changes = np.concatenate([[True], np.diff(clock) != 0])
        np.testing.assert_array_equal(clock[changes], stamps_expected)
        harness.spin_until(
            lambda: (
                our_diagnostics(harness, 'paused', 'false')
                and our_diagnostics(harness, 'paused', 'false')[1].get('stamp_shift')
                == f'{shift // 10**9}.{shift % 10**9:09d}'
            ),
            what='the shift in /diagnostics',
        )


# -- lock-step ------------------------------------------------------------------------------------


def test_a_pause_in_lockstep_holds_the_loop_and_the_run_is_bit_for_bit_the_unpaused_one(tmp_path):
    from test_closed_loop import _run, _scene
    from test_closed_loop import RATE as LOCKSTEP_RATE
    from test_closed_loop import RateDamper

    scene = _scene(tmp_path)
    period = round(1e9 / LOCKSTEP_RATE)
    count = 60
    with connected_harness(
        publish_rate=LOCKSTEP_RATE,
        real_time_factor=0.0,
        lockstep=True,
        lockstep_timeout=20.0,
        scene=str(scene),
    ) as harness:
        client = pause_client(harness)
        RateDamper(harness)
        loop = harness.node.sample_loop
        assert harness.set_parameters(scene=str(scene))[0].successful
        response = harness.reset()
        assert response.success, response.message
        epoch = reset_epoch_ns(response)
        harness.wait_samples(20, after=epoch - 1)
        # the loop is waiting for the controller, or computing
        response = call_pause(harness, client, True)
        k = paused_at(response)
        held = epoch + (k - 1) * period
        assert loop.last.index == k - 1 and '/clock holds at' in response.message
        # the controller's answer to k - 1 arrives: still nothing goes out
        spin_for(harness, PAUSED_SPIN)
        assert loop.last.index == k - 1 and max(harness.omega) == held
        harness.spin_until(lambda: harness.clock.count(held) >= 2, what='the held clock')
        assert max(harness.clock) == held
        assert resumed_at(call_pause(harness, client, False)) == k
        stamps = [epoch + j * period for j in range(count)]
        harness.spin_until(
            lambda: all(s in harness.omega and s in harness.q for s in stamps),
            timeout=60.0,
            what=f'{count} closed-loop samples',
        )
        omega = np.array([harness.omega[s] for s in stamps])
        q = np.array([harness.q[s] for s in stamps])
        assert loop.missed_steps == 0  # the pause cut a wait short; it is not a missed step
        # the same controller, a run never paused: bit for bit
        _, omega_unpaused, q_unpaused = _run(harness, scene, count)
    np.testing.assert_array_equal(omega, omega_unpaused)
    np.testing.assert_array_equal(q, q_unpaused)


def test_a_pause_in_a_wall_clock_closed_loop_moves_the_command_hold_with_the_stamps(tmp_path):
    """
    A pause in a wall-clock closed loop moves the command hold with the stamps.

    Paused longer than the command timeout: the command in force still holds on resuming (the
    timeout counts simulated time, which stood still), and the controller's answers to the shifted
    samples are taken.
    """
    from test_closed_loop import _scene, RateDamper

    scene = _scene(tmp_path)  # timeout 0.5 s
    with connected_harness(publish_rate=20.0, scene=str(scene)) as harness:
        client = pause_client(harness)
        RateDamper(harness)
        loop = harness.node.sample_loop
        ((effect, hold),) = loop.simulation.command_holds
        harness.spin_until(lambda: hold.accepted >= 5, what="the controller's commands")
        k = paused_at(call_pause(harness, client, True))
        spin_for(harness, 0.6)
        assert hold.in_force(k) is not None
        accepted = hold.accepted
        shift = shift_ns(call_pause(harness, client, False))
        assert shift >= 0.6e9
        assert hold.epoch_ns == loop.simulation.epoch_ns
        # 0.6 s paused, yet not timed out
        assert hold.in_force(k) is not None and not hold.timed_out(k)
        harness.spin_until(
            lambda: hold.accepted >= accepted + 5, what='answers to the resumed samples'
        )
        assert not hold.refused, hold.refused
        # an answer holds from the sample it answers (the grid moved with the stamps), or from the
        # next one when it came after that interval was sealed
        command = hold.commands[-1]
        answered, remainder = divmod(
            command.stamp_ns - loop.simulation.epoch_ns, round(1e9 / 20.0)
        )
        assert remainder == 0 and command.start - answered in (0, 1)


# -- recording ------------------------------------------------------------------------------------


@pytest.mark.parametrize('factor', [1.0, 2.0], ids=['wall_clock', 'own_clock'])
def test_a_pause_while_recording_shows_in_the_bag_as_the_gap_in_time_and_nothing_else(
    tmp_path, factor
):
    from bag_checks import read_with_rosbags

    bag = tmp_path / 'paused'
    with connected_harness(
        publish_rate=RATE, real_time_factor=factor, record_bag=str(bag)
    ) as harness:
        client = pause_client(harness)
        loop = harness.node.sample_loop
        harness.wait_samples(20)
        k = paused_at(call_pause(harness, client, True))
        spin_for(harness, PAUSED_SPIN)
        response = call_pause(harness, client, False)
        shift = shift_ns(response) if factor == 1.0 else 0
        harness.spin_until(lambda: loop.published >= k + 20, what='samples after resuming')
        namespace = harness.node.get_namespace()
    published = loop.published  # the node closed its bag
    messages, _ = read_with_rosbags(bag)
    clock = {'/clock'} if factor != 1.0 else set()
    assert set(messages) == {f'{namespace}/angular_velocity', f'{namespace}/attitude'} | clock
    omega, attitude = messages[f'{namespace}/angular_velocity'], messages[f'{namespace}/attitude']
    # every sample once: nothing while paused, nothing twice
    assert len(omega) == len(attitude) == published
    log = np.array([log for log, _ in omega])
    stamps = np.array([stamp_ns(m.header.stamp) for _, m in omega])
    np.testing.assert_array_equal(stamps, log)
    np.testing.assert_array_equal([stamp_ns(m.header.stamp) for _, m in attitude], log)
    # contiguous in index: sample j of the bag is the exact state at t_j
    assert_exact(
        np.arange(published),
        [[m.vector.x, m.vector.y, m.vector.z] for _, m in omega],
        [[m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w] for _, m in attitude],
    )
    # in time: the gap of the pause (wall clock), or none at all (the clock held)
    expected = (
        log[0] + np.arange(published) * PERIOD + np.where(np.arange(published) >= k, shift, 0)
    )
    np.testing.assert_array_equal(log, expected)
    if factor != 1.0:  # /clock in the bag: one per sample, none of the held ones
        np.testing.assert_array_equal([stamp_ns(m.clock) for _, m in messages['/clock']], log)
    else:
        assert shift >= PAUSED_SPIN * 1e9


# -- a reset while paused -------------------------------------------------------------------------


@pytest.mark.parametrize('factor', [2.0, 1.0], ids=['own_clock', 'wall_clock'])
def test_a_reset_while_paused_starts_the_new_run_paused(factor):
    with connected_harness(publish_rate=RATE, real_time_factor=factor) as harness:
        client = pause_client(harness)
        loop = harness.node.sample_loop
        harness.wait_samples(5)
        k = paused_at(call_pause(harness, client, True))
        assert harness.set_parameters(angular_velocity=[0.1, 0.2, 0.3])[0].successful
        response = harness.reset()
        assert (
            response.success
            and 'paused: its sample 0 goes out when ~/pause false resumes' in response.message
        )
        assert ('its stamps then move on by the time paused' in response.message) == (
            factor == 1.0
        )
        epoch = reset_epoch_ns(response)
        if factor != 1.0:
            assert epoch == k * PERIOD  # the clock of our own keeps its cadence across the reset
        spin_for(harness, PAUSED_SPIN)
        assert loop.last.index == k - 1 and loop.last.simulation is not loop.simulation
        assert max(harness.omega) < epoch  # nothing of the new run
        status = call_pause(harness, client, True)
        assert status.message.startswith('already paused at sample 0 (t = 0 s)'), status.message
        response = call_pause(harness, client, False)
        assert resumed_at(response) == 0
        first = epoch + (shift_ns(response) if factor == 1.0 else 0)
        if factor == 1.0:
            assert shift_ns(response) >= PAUSED_SPIN * 1e9  # paused from the reset on
        harness.spin_until(
            lambda: first in harness.omega and first in harness.q, what="the new run's sample 0"
        )
        np.testing.assert_array_equal(harness.omega[first], [0.1, 0.2, 0.3])
        np.testing.assert_array_equal(harness.q[first], DEFAULT.orientation)
