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
The simulator's samples as messages: their topics, their CDR bytes, and writing them to a bag.

One source for the node (which publishes and records them) and the offline ``torquefree_bag``: the
same topics, types, QoS, stamps and bytes.

A sample is ``/clock`` (on a clock of our own), ``angular_velocity``, ``attitude``, then the
scene's outputs (``imu``, ``pose``, ``odometry``, ``markers``, ...) in the order the scene names
them; only those exist.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from .cdr import encode_joint_state, encode_stamped_doubles, encode_times
from .layouts import LAYOUTS, orbit_frames
from .markers import body_offset
from .qos import BagQos
from .writer import BagWriter

ANGULAR_VELOCITY = ('angular_velocity', 'geometry_msgs/msg/Vector3Stamped')
ATTITUDE = ('attitude', 'geometry_msgs/msg/QuaternionStamped')
CLOCK = ('/clock', 'rosgraph_msgs/msg/Clock')
JOINT_STATE = 'sensor_msgs/msg/JointState'
#: output layouts whose rows start with the body's position (x, y, z)
PLACED = ('transform', 'pose', 'odometry')
#: custom_data key of the body's inertia (3 or 6 numbers, space-separated) in offline bags
INERTIA_KEY = 'torquefree_ros.inertia'


class SampleColumn(NamedTuple):
    topic: str  # as the node names it: relative, or absolute for /clock
    type_name: str
    # CDR bytes, one per sample of the block (None: this sample does not go out on it)
    messages: list


def sample_qos(depth: int = 10) -> BagQos:
    """
    Return the QoS the node's publishers offer.

    Reliable, keep-last ``depth``, volatile, no deadline.
    """
    return BagQos(history='keep_last', depth=depth, reliability='reliable', durability='volatile')


def resolve_topic(name: str, namespace: str = '/') -> str:
    if name.startswith('/'):
        return name
    return namespace.rstrip('/') + '/' + name


def encode_block(
    block, body_frame: str, inertial_frame: str, outputs=(), clock: bool = False, position=None
) -> tuple:
    """
    Encode a :class:`~torquefree_ros.core.run.simulation.SampleBlock`'s messages, a column a topic.

    The columns are in publishing order: :func:`encode_leading` then :func:`encode_trailing`.
    ``outputs``: the simulation's output effects (their rows are in the block). ``position`` (x,
    y, z, m, in the inertial frame; None: the origin): where the outputs that place the body
    (``tf``, ``pose``, ``odometry``, ``markers``) put its centre, so that several bodies sharing
    one inertial frame show side by side; the simulator moves attitude only, so it is constant.
    """
    return encode_leading(block, body_frame, clock) + encode_trailing(
        block, body_frame, inertial_frame, outputs, position
    )


def encode_leading(block, body_frame: str, clock: bool = False) -> tuple:
    """
    Encode the columns that go out first: ``/clock`` (when ``clock``), then ``angular_velocity``.

    Apart so that a closed loop publishes the rates its controller answers before it computes
    and encodes the rest (:meth:`~torquefree_ros.core.run.simulation.Simulation.with_outputs`).
    """
    stamps = block.stamps_ns
    rates = SampleColumn(
        *ANGULAR_VELOCITY, encode_stamped_doubles(stamps, body_frame, block.omega_B)
    )
    return (SampleColumn(CLOCK[0], CLOCK[1], encode_times(stamps)), rates) if clock else (rates,)


def encode_trailing(
    block, body_frame: str, inertial_frame: str, outputs=(), position=None
) -> tuple:
    """Encode the columns after :func:`encode_leading`'s: ``attitude``, then the outputs'."""
    if len(block.outputs) < len(outputs):
        raise ValueError(
            f'the block has rows for {len(block.outputs)} outputs, not {len(outputs)} '
            '(Simulation.with_outputs adds them)'
        )
    place = body_offset(position)
    stamps = block.stamps_ns
    columns = [
        SampleColumn(*ATTITUDE, encode_stamped_doubles(stamps, inertial_frame, block.q_NB))
    ]
    for output, rows, positions in zip(
        outputs, block.outputs, block.output_positions or (None,) * len(outputs)
    ):
        if positions is None:
            messages = _encode_output(output, stamps, rows, body_frame, inertial_frame, place)
        else:  # an output at a rate of its own: None where it does not go out
            messages = [None] * len(stamps)
            encoded = _encode_output(
                output, stamps[positions], rows, body_frame, inertial_frame, place
            )
            for index, message in zip(positions.tolist(), encoded):
                messages[index] = message
        columns.append(SampleColumn(output.topic, output.message_type, messages))
    return tuple(columns)


def check_output_frames(outputs, body_frame: str, inertial_frame: str) -> None:
    """
    Raise ``ValueError`` naming the output when its messages' frames would clash.

    The same rule the encoding applies (``layouts.orbit_frames``), checked before a run starts so
    that a clash is refused there rather than found at the first sample.
    """
    for output in outputs:
        if output.layout == 'orbit_transforms':
            try:
                orbit_frames(
                    _output_frame(output, body_frame, inertial_frame),
                    body_frame,
                    **output.layout_options,
                )
            except ValueError as error:
                raise ValueError(f'{output.name} output: {error}') from None


def _output_frame(output, body_frame: str, inertial_frame: str) -> str:
    return body_frame if output.frame == 'body' else inertial_frame


def _encode_output(
    output, stamps, rows, body_frame: str, inertial_frame: str, place
) -> list[bytes]:
    frame = _output_frame(output, body_frame, inertial_frame)
    if place is not None and output.layout in PLACED:
        rows = rows.copy()
        # these rows start with the body's position (zero: the core moves no body)
        rows[:, 0:3] = place
    return LAYOUTS[output.layout](
        stamps, frame, body_frame, rows, place, **output.layout_options
    )


def encode_command(command, effect=None) -> bytes:
    """
    Encode a received command as its effect's message, for the bag.

    ``torque_command`` (or no ``effect``): a ``geometry_msgs/WrenchStamped`` with the command's own
    stamp, frame, force (zero when none came) and torque. ``reaction_wheels``: a
    ``sensor_msgs/JointState`` with its stamp and frame, every wheel named in the effect's order,
    the values that hold (a command naming some wheels, merged) in ``effort`` or ``velocity``.
    ``magnetorquers``: a ``geometry_msgs/Vector3Stamped`` with its stamp, frame and the dipole
    asked for.
    """
    if effect is not None and effect.message_type == ANGULAR_VELOCITY[1]:  # Vector3Stamped
        return encode_stamped_doubles([command.stamp_ns], command.frame_id, [command.values])[0]
    if effect is not None and effect.message_type == JOINT_STATE:
        values = command.values.tolist()
        velocity, effort = (values, ()) if effect.command_field == 'velocity' else ((), values)
        return encode_joint_state(
            command.stamp_ns, command.frame_id, effect.names, (), velocity, effort
        )
    force = command.force if command.force.size else np.zeros(3)
    values = np.concatenate([force, command.values])[np.newaxis]
    return encode_stamped_doubles([command.stamp_ns], command.frame_id, values)[0]


class SampleRecorder:
    """
    Writes sample columns on ``writer``; a topic's channel is added the first time it is written.

    ``resolve`` maps a column's topic to the name it goes out on (the node passes its publishers'
    resolved, possibly remapped names; offline, relative names go into ``namespace``).
    """

    def __init__(
        self, writer: BagWriter, resolve: Callable[[str], str], qos: BagQos | None = None
    ):
        self.writer = writer
        self._resolve = resolve
        self._qos = (qos or sample_qos(),)
        self._channels: dict[str, int] = {}

    @classmethod
    def in_namespace(
        cls, writer: BagWriter, namespace: str = '/', qos: BagQos | None = None
    ) -> 'SampleRecorder':
        return cls(writer, lambda topic: resolve_topic(topic, namespace), qos)

    def _channel(self, column: SampleColumn) -> int:
        channel = self._channels.get(column.topic)
        if channel is None:
            channel = self.writer.add_topic(
                self._resolve(column.topic), column.type_name, self._qos
            )
            self._channels[column.topic] = channel
        return channel

    def write_block(self, stamps_ns, columns) -> None:
        """
        Write every sample of a block: for sample ``i``, every column's message ``i``.

        The messages of sample ``i`` go in column order, logged at the sample's stamp.
        """
        self.writer.write_rows(
            [self._channel(column) for column in columns],
            stamps_ns,
            [column.messages for column in columns],
        )

    def declare(self, topic: str, type_name: str) -> None:
        """
        Add a topic that is not a sample column (a command input) to the bag.

        It is in the bag from the start of the run that has it, with or without messages.
        """
        self._channel(SampleColumn(topic, type_name, []))

    def write_message(self, topic: str, type_name: str, log_stamp_ns: int, data: bytes) -> None:
        """Write one message of a topic that is not a sample column (a received command)."""
        self.writer.write_rows(
            [self._channel(SampleColumn(topic, type_name, []))], (log_stamp_ns,), [(data,)]
        )

    def write_sample(self, stamp_ns: int, columns, index: int) -> None:
        """
        Write sample ``index`` of the block ``columns`` belong to.

        The node records as it publishes, a sample at a time.
        """
        self.writer.write_rows(
            [self._channel(column) for column in columns],
            (stamp_ns,),
            [(column.messages[index],) for column in columns],
        )
