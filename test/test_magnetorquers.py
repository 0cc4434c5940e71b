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
The ``magnetorquers`` effect (issue 41): rods commanded with a body dipole, ``m x B`` on the orbit.

The references never go through the code under test: the field from the environment module at
the exact instant, rotations by scipy and the cross product by numpy; the rods' dipoles of
orthonormal rods as their projections clipped by hand, of a pyramid by numpy's least squares;
Euler's law in the inertial frame by quadrature; the node's samples against the core's simulation
driven by the same commands, and its recording against the offline replay of that recording.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import simpson
from scipy.spatial.transform import Rotation
from torquefree_ros.core.compiled import drivers
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

EPS = np.finfo(float).eps
#: a 500 km orbit, inclined, slightly eccentric
LEO = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.001,
    'inclination': 1.7,
    'raan': 0.3,
    'argument_of_perigee': 0.5,
    'mean_anomaly': 0.2,
}
INERTIA = [0.03, 0.035, 0.01]  # a 3U-class body, kg m^2
#: three orthonormal rods turned away from the body axes, each with its own limit
TURN = Rotation.from_rotvec([0.4, -0.3, 0.7])
ROD_AXES = TURN.as_matrix().T  # rows: the rods' axes
LIMITS = np.array([0.2, 0.1, 0.05])  # A m^2
RODS = [
    {'axis': axis.tolist(), 'max_dipole': float(limit)} for axis, limit in zip(ROD_AXES, LIMITS)
]


def scene(effect=None, orbit=LEO, omega=(0.02, 0.05, -0.03), outputs=(), **extra):
    data = {
        'body': {'inertia': list(INERTIA)},
        'initial': {'angular_velocity': list(omega)},
        'effects': [{'magnetorquers': {'rods': RODS, **(effect or {})}}, *outputs],
        **extra,
    }
    if orbit is not None:
        data['orbit'] = orbit
    return scene_from_mapping(data, source='s.yaml')


def clipped_by_hand(wanted):
    """Orthonormal rods: rod i takes ``a_i . m*`` (the least-norm split), clipped to its limit."""
    projections = ROD_AXES @ np.asarray(wanted, dtype=float)
    return np.clip(projections, -LIMITS, LIMITS) @ ROD_AXES


def _run(s, rate=1.0):
    simulation = Simulation(s.propagator(), rate, outputs=s.outputs)
    ((effect, hold),) = simulation.command_holds
    hold.frame_id = 'body'
    return simulation, effect, hold


# -- the torque -----------------------------------------------------------------------------------
@pytest.mark.parametrize('field', ['igrf', 'dipole'])
def test_the_torque_is_the_applied_dipole_cross_the_body_field(field):
    """
    ``m x B_B`` on both paths, ``B`` from the environment module, scipy's rotation, numpy's cross.

    Against the field the torque holds (the window's interpolant, ``Place.evaluate``): to rounding,
    8 eps of ``|m| |B|``. Against the exact field at the instant (``Place.field_N``): within the
    held field's error, 3e-12 of ``|B|`` (environment.place), so 1e-11 of ``|m| |B|``.
    """
    s = scene({'field': field})
    simulation, effect, hold = _run(s)
    wanted = [0.03, -0.02, 0.01]  # inside every rod's limit: the rods apply it
    assert effect.receive(0, 'body', wanted) == (True, '')
    m = np.asarray(wanted)
    np.testing.assert_allclose(effect.held_slot(0.0), m, rtol=0, atol=4 * EPS * 0.03)
    place, dynamics = s.orbit, simulation.propagator.dynamics
    quantity = ('position', 'igrf', 'dipole').index(field)
    rng = np.random.default_rng(11)
    times = rng.uniform(0.0, 0.99, 6)  # all in interval 0, where the command holds
    qs = Rotation.random(6, random_state=rng).as_quat()
    states = np.hstack([np.zeros((6, 3)), qs])  # at rest: w' = I^-1 torque
    compiled = drivers.derivatives(dynamics, times, states) if switch.AVAILABLE else None
    for i, (t, q) in enumerate(zip(times, qs)):
        turn = Rotation.from_quat(q).inv()
        held_B = turn.apply(place.evaluate(quantity, t, t))
        exact_N = place.field_N(t, place.state(t)[0], field)
        size = np.linalg.norm(m) * np.linalg.norm(exact_N)
        got = effect.torque_B(t, np.zeros(3), q, np.empty(0), t)
        np.testing.assert_allclose(got, np.cross(m, held_B), rtol=0, atol=8 * EPS * size)
        np.testing.assert_allclose(
            got, np.cross(m, turn.apply(exact_N)), rtol=0, atol=1e-11 * size
        )
        if compiled is not None:  # the kernel: I w' at rest is the torque
            np.testing.assert_allclose(
                np.multiply(INERTIA, compiled[i, :3]), got, rtol=0, atol=8 * EPS * size
            )


@pytest.mark.usefixtures('integrator_path')
def test_the_inertial_momentum_changes_by_the_integral_of_the_torque():
    """
    Euler's law in the inertial frame: ``H_N(t) - H_N(0) = int (R m) x B_N dt``, under commands.

    Four commands, two saturating a rod, held from their samples (1 Hz). The integral by Simpson's
    rule on 0.02 s samples of the propagated attitude, piece by piece between the commands (the
    torque jumps there), with the exact field (``Place.field_N``, 3e-12 of |B| from the held one)
    and the dipoles clipped by hand; the propagation at rtol 1e-12. Bound: 1e-9 of the change
    (the integral's error, h^4 w^4 / 180 of the torque, is 1e-12 of it here).
    """
    s = scene({'timeout': 100.0}, accuracy=1e-12)
    simulation, effect, hold = _run(s)
    commands = {0: [0.1, -0.02, 0.03], 10: [0.5, 0.4, -0.3], 25: [-0.01, 0.2, 0.02], 40: [0, 0, 1]}
    for k, wanted in commands.items():
        assert effect.receive(hold.stamp_ns(k), 'body', wanted)[0]
    p = simulation.propagator
    starts = sorted(commands) + [60]
    change = np.zeros(3)
    omega, q, x = p.states(np.arange(0.0, 60.0 + 1e-9, 0.02))
    momentum_N = Rotation.from_quat(q).apply(p.momentum_B(omega, x))
    for start, end in zip(starts[:-1], starts[1:]):
        times = np.linspace(start, end, round((end - start) / 0.02) + 1)
        _, q_piece = p.states(times)[:2]
        field_N = s.orbit.field_N(times, s.orbit.state(times)[0], 'igrf')
        m_N = Rotation.from_quat(q_piece).apply(clipped_by_hand(commands[start]))
        change += simpson(np.cross(m_N, field_N), x=times, axis=0)
    assert clipped_by_hand(commands[10]).tolist() != commands[10]  # saturated
    np.testing.assert_allclose(
        momentum_N[-1] - momentum_N[0], change, rtol=0, atol=1e-9 * np.linalg.norm(change)
    )
    assert np.linalg.norm(change) > 1e-3 * np.linalg.norm(momentum_N[0])  # a real change


# -- the rods -------------------------------------------------------------------------------------
def test_each_rod_saturates_on_its_own():
    """
    Orthonormal rods: each clipped to its own limit; a pyramid: numpy's least-norm split, clipped.

    Both to rounding (16 eps of the largest dipole): the same linear algebra by another route.
    """
    (effect,) = scene().effects
    for wanted in ([0.01, 0.02, -0.01], [0.5, -0.05, -0.3], [-3.0, 2.0, 1.0], [0.0, 0.0, 0.0]):
        expected = clipped_by_hand(wanted)
        np.testing.assert_allclose(effect.applied_dipole(wanted), expected, rtol=0, atol=1e-16)
        rods = effect.rod_dipoles(wanted)
        assert np.all(np.abs(rods) <= LIMITS)
    assert np.abs(effect.rod_dipoles([-3.0, 2.0, 1.0])).tolist() == LIMITS.tolist()
    pyramid = [
        {'axis': [math.cos(a), math.sin(a), 1.0], 'max_dipole': 0.15}
        for a in np.radians([0.0, 90.0, 180.0, 270.0])
    ]
    (effect,) = scene({'rods': pyramid}).effects
    axes = np.array([r['axis'] for r in pyramid])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    for wanted in ([0.05, -0.02, 0.1], [0.4, 0.1, -0.2]):
        least_norm = np.linalg.lstsq(axes.T, np.asarray(wanted), rcond=None)[0]
        expected = np.clip(least_norm, -0.15, 0.15) @ axes
        np.testing.assert_allclose(
            effect.applied_dipole(wanted), expected, rtol=0, atol=16 * EPS * 0.4
        )
    # the first is inside the limits: the rods make it exactly; the second is not
    np.testing.assert_allclose(effect.applied_dipole([0.05, -0.02, 0.1]), [0.05, -0.02, 0.1],
                               rtol=0, atol=16 * EPS)
    assert np.abs(effect.rod_dipoles([0.4, 0.1, -0.2])).max() == 0.15


def test_a_command_holds_from_its_sample_until_the_timeout_and_the_output_follows():
    """
    Held from the first sample at or after its stamp; zero at exactly ``timeout`` after it.

    2 Hz, timeout 2 s, stamped 0.9 s: it holds from the interval of 1.0 s (k = 2) until the first
    sample at least 2 s after its stamp, k = 6 (t_6 - 0.9 = 2.1; t_5 - 0.9 = 1.6); stamped 1.0 s,
    k = 6 is exactly 2 s after it: off there too. ``magnetorquer_dipole`` at sample k reports the
    dipole of interval k - 1.
    """
    s = scene({'timeout': 2.0}, outputs=[{'magnetorquer_dipole': {}}])
    simulation, effect, hold = _run(s, rate=2.0)
    assert effect.receive(900_000_000, 'body', [0.5, 0.0, 0.0])[0]
    applied = clipped_by_hand([0.5, 0.0, 0.0])
    held = [effect.held_slot(k / 2.0).tolist() for k in range(10)]
    on = [k for k in range(10) if any(held[k])]
    assert on == [2, 3, 4, 5]
    np.testing.assert_allclose(held[2], applied, rtol=0, atol=1e-16)
    assert not any(effect.held_slot(math.nextafter(1.0, 0.0)))  # still interval 1
    block = simulation.samples(0, 10)
    (rows,) = block.outputs
    assert [k for k in range(10) if rows[k].any()] == [3, 4, 5, 6]
    np.testing.assert_allclose(rows[3], applied, rtol=0, atol=1e-16)
    # exactly at the timeout: the stamp 1.0 s holds from k = 2 and times out at k = 6 (t = 3.0)
    _, effect, hold = _run(s, rate=2.0)
    assert effect.receive(1_000_000_000, 'body', [0.5, 0.0, 0.0])[0]
    assert [k for k in range(10) if hold.in_force(k) is not None] == [2, 3, 4, 5]
    assert hold.timed_out(6) and not hold.timed_out(5)


# -- bad input ------------------------------------------------------------------------------------
BAD_SCENES = {
    'no orbit': (
        {},
        {'orbit': None},
        r"effects\[0\]\.magnetorquers: needs the scene's orbit",
    ),
    'fewer than three rods': (
        {'rods': RODS[:2]},
        {},
        r'effects\[0\]\.magnetorquers\.rods: expected at least 3 entries, got 2',
    ),
    'a zero axis': (
        {'rods': [RODS[0], {'axis': [0.0, 0.0, 0.0], 'max_dipole': 0.1}, RODS[2]]},
        {},
        r'effects\[0\]\.magnetorquers\.rods\[1\]\.axis: must not be the zero vector',
    ),
    'rods in a plane': (
        {'rods': [{'axis': a, 'max_dipole': 0.1} for a in ([1, 0, 0], [0, 1, 0], [1, 1, 0])]},
        {},
        r'effects\[0\]\.magnetorquers\.rods: the axes must span 3-D .* lie in a plane',
    ),
    'rods on a line': (
        {'rods': [{'axis': a, 'max_dipole': 0.1} for a in ([1, 0, 0], [-2, 0, 0], [3, 0, 0])]},
        {},
        r'effects\[0\]\.magnetorquers\.rods: the axes must span 3-D .* lie in a line',
    ),
    'a zero max_dipole': (
        {'rods': [*RODS[:2], {'axis': [0, 0, 1], 'max_dipole': 0.0}]},
        {},
        r'effects\[0\]\.magnetorquers\.rods\[2\]\.max_dipole: must be > 0 A m\^2',
    ),
    'a negative max_dipole': (
        {'rods': [{'axis': [1, 0, 0], 'max_dipole': -0.2}, *RODS[1:]]},
        {},
        r'effects\[0\]\.magnetorquers\.rods\[0\]\.max_dipole: must be > 0 A m\^2',
    ),
    'a rod without max_dipole': (
        {'rods': [{'axis': [1, 0, 0]}, *RODS[1:]]},
        {},
        r'effects\[0\]\.magnetorquers\.rods\[0\]\.max_dipole: ',
    ),
    'an unknown field model': (
        {'field': 'wmm'},
        {},
        r'effects\[0\]\.magnetorquers\.field: ',
    ),
    'a zero timeout': (
        {'timeout': 0.0},
        {},
        r'effects\[0\]\.magnetorquers\.timeout: must be > 0 s',
    ),
    'a zero max_command': (
        {'max_command': 0},
        {},
        r'effects\[0\]\.magnetorquers\.max_command: must be > 0 A m\^2',
    ),
    'a bad topic': (
        {'topic': '2bad'},
        {},
        r'effects\[0\]\.magnetorquers\.topic: ',
    ),
    'a start past the field model': (
        {},
        {'orbit': {**LEO, 'epoch': '2031-01-01T00:00:00Z'}},
        r'orbit\.epoch: ',
    ),
}


@pytest.mark.parametrize('label', BAD_SCENES)
def test_bad_scenes_are_refused_with_the_field_path(label):
    effect, extra, reason = BAD_SCENES[label]
    with pytest.raises(SceneError, match=reason):
        scene(effect, **extra)


def test_the_dipole_output_needs_magnetorquers():
    with pytest.raises(SceneError, match=r'effects\[0\]\.magnetorquer_dipole: reports on a '):
        scene_from_mapping(
            {
                'body': {'inertia': INERTIA},
                'initial': {'angular_velocity': [0.0, 0.0, 0.1]},
                'effects': [{'magnetorquer_dipole': {}}],
                'orbit': LEO,
            }
        )


@pytest.mark.parametrize(
    'dipole, frame_id, reason',
    [
        ([float('nan'), 0.0, 0.0], 'body', 'not finite'),
        ([0.0, float('inf'), 0.0], 'body', 'not finite'),
        ([0.0, 0.0, -11.0], 'body', 'too large'),
        ([0.0, 0.0, 0.1], 'world', 'wrong frame'),
        ([0.0, 0.0, 0.1], '', 'wrong frame'),
        ([0.0, 0.0, 0.1], 'x' * 100_000, 'wrong frame'),
    ],
)
def test_bad_commands_are_refused_counted_and_never_reach_the_state(dipole, frame_id, reason):
    s = scene({'max_command': 10.0})
    simulation, effect, hold = _run(s)
    untouched, _, _ = _run(s)
    accepted, text = effect.receive(0, frame_id, dipole)
    assert not accepted and text.startswith(reason + ':') and len(text) < 300
    assert dict(hold.refused) == {reason: 1} and not hold.commands
    np.testing.assert_array_equal(
        simulation.samples(0, 4).omega_B, untouched.samples(0, 4).omega_B
    )


def test_a_stale_command_is_dropped_and_counted():
    _, effect, hold = _run(scene())
    assert effect.receive(2_000_000_000, 'body', [0.1, 0.0, 0.0])[0]
    assert effect.receive(1_000_000_000, 'body', [0.0, 0.1, 0.0]) == (
        False,
        'stale: stamped before the latest accepted command',
    )
    assert dict(hold.refused) == {'stale': 1} and hold.accepted == 1


# -- the node -------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    'sec, nanosec, frame_id, vector',
    [
        (0, 0, 'body', (0.1, -0.2, 0.05)),
        (1_700_000_000, 999_999_999, 'ns/sat_body', (float('nan'), float('inf'), -0.0)),
        (-(2**31), 1, '', (1e300, -1e-300, 5e-324)),
        (17, 3, 'ünïcode', (-3.0, 2.0, 1.0)),
    ],
)
def test_a_command_decodes_as_rclpy_serializes_it(sec, nanosec, frame_id, vector):
    """The node's struct decoder reads rclpy's own serialization, every bit of every number."""
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.serialization import serialize_message
    from torquefree_ros.ros.commands import decode_vector_command

    message = Vector3Stamped()
    message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
    message.header.frame_id = frame_id
    message.vector.x, message.vector.y, message.vector.z = vector
    stamp, frame, got = decode_vector_command(serialize_message(message))
    assert (stamp, frame) == (sec * 1_000_000_000 + nanosec, frame_id)
    np.testing.assert_array_equal(np.array(got).view(np.int64), np.array(vector).view(np.int64))


def test_diagnostics_name_the_dipole_in_force_and_its_timeout():
    from torquefree_ros.ros.commands import command_diagnostics

    simulation, effect, hold = _run(scene({'timeout': 2.0}))
    values, warning = command_diagnostics(simulation.command_holds, 0, 0, False)
    assert values['magnetorquer_command.dipole'] == 'zero dipole (no command in force)'
    assert warning == ''
    assert effect.receive(0, 'body', [0.1, 0.0, -0.02])[0]
    assert not effect.receive(0, 'body', [0.0, float('nan'), 0.0])[0]
    values, warning = command_diagnostics(simulation.command_holds, 1, 0, False)
    assert values['magnetorquer_command.dipole'] == '0.1 0 -0.02'
    assert values['magnetorquer_command.refused'] == 'not finite 1'
    values, warning = command_diagnostics(simulation.command_holds, 2, 0, False)
    assert warning == 'magnetorquer_command: no command for 2 s: the dipole is zero'


NODE_RATE = 2.0
NODE_SCENE = f"""
body: {{inertia: {INERTIA}}}
initial: {{angular_velocity: [0.05, -0.04, 0.06]}}
orbit: {{epoch: '2026-03-20T12:00:00Z', semi_major_axis: 6878137.0, inclination: 1.7}}
effects:
  - magnetorquers:
      timeout: 1.0
      rods: {RODS}
  - magnetorquer_dipole: {{}}
accuracy: 1.0e-10
"""


def _answers(k: int) -> list:
    """Return the dipole answering sample ``k`` (some saturate a rod, some do not)."""
    return [0.3 * math.sin(0.7 * k), 0.02 * k % 0.15, -0.04]


def test_the_node_takes_commands_in_lockstep_and_its_recording_replays_bit_for_bit(tmp_path):
    """
    A controller answering every sample: the next sample shows its dipole, the offline replay all.

    The node's samples equal the core's simulation fed the same answers (bit for bit: the same
    engine and the same hold); ``magnetorquer_dipole`` at sample k + 1 is the answer to k, clipped
    by hand; ``torquefree_bag --commands`` re-simulates the recording into the same bytes.
    """
    from geometry_msgs.msg import Vector3Stamped
    from torquefree_ros.bag.offline import write_scene_bag
    from torquefree_ros.bag.reader import BagReader
    from torquefree_ros.core.scene.loader import load_scene
    from torquefree_ros.testing import simulator

    path = tmp_path / 'plant.yaml'
    path.write_text(NODE_SCENE)
    recorded = tmp_path / 'live'
    count = 40
    with simulator(str(path), publish_rate=NODE_RATE, record_bag=str(recorded)) as sim:
        controller = sim.create_node('controller')
        publisher = controller.create_publisher(Vector3Stamped, 'magnetorquer_command', 10)

        def answer(sample):
            k = round(sim.time_of(sample.header.stamp) * NODE_RATE)
            command = Vector3Stamped()
            command.header = sample.header  # the sample's stamp, the body frame
            command.vector.x, command.vector.y, command.vector.z = _answers(k)
            publisher.publish(command)

        controller.create_subscription(Vector3Stamped, 'angular_velocity', answer, 10)
        applied = sim.tap('magnetorquer_dipole', Vector3Stamped)
        samples = sim.advance(count)
        applied.wait(count)
        assert sim.node.stepping.state().missed_steps == 0
    epoch = samples[0].stamp_ns
    got = np.array([[m.vector.x, m.vector.y, m.vector.z] for m in applied.messages])
    np.testing.assert_array_equal(got[0], 0.0)
    expected = np.array([clipped_by_hand(_answers(k)) for k in range(count - 1)])
    np.testing.assert_allclose(got[1:], expected, rtol=0, atol=1e-16)
    assert np.any(expected != [_answers(k) for k in range(count - 1)])  # some saturated
    # the core, fed the same answers: the same samples, bit for bit
    simulation, effect, hold = _run(load_scene(str(path)), rate=NODE_RATE)
    rows = []
    for k in range(count):
        rows.append(simulation.samples(k, 1).omega_B[0])
        effect.receive(hold.stamp_ns(k), 'body', _answers(k))
        hold.seal(k)
    np.testing.assert_array_equal([s.angular_velocity for s in samples], rows)
    # the recording re-simulated offline from its commands: the same bytes on every sample topic
    replay = tmp_path / 'replay'
    write_scene_bag(
        load_scene(str(path)),
        replay,
        (count - 1) / NODE_RATE,
        NODE_RATE,
        epoch_ns=epoch,
        commands_bag=recorded,
    )
    window = (epoch, epoch + (count - 1) * round(1e9 / NODE_RATE))

    def messages(bag):
        by_topic = {}
        for m in BagReader(bag).messages():
            if window[0] <= m.log_time_ns <= window[1]:
                by_topic.setdefault(m.topic, []).append(m.data)
        return by_topic

    live, again = messages(recorded), messages(replay)
    for topic in ('/angular_velocity', '/attitude', '/magnetorquer_dipole'):
        assert len(live[topic]) == count and live[topic] == again[topic], topic
    # the commands that held are in both, logged where they held from
    held = count - 1  # (the answer to the last sample is logged once a next sample seals it)
    assert live['/magnetorquer_command'][:held] == again['/magnetorquer_command'][:held]
