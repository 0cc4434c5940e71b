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
A scene simulated offline, as fast as possible, into a bag (``torquefree_bag``).

No DDS: the samples come from the same ``Simulation`` and CDR encoder as the node's, so the bag
holds what the node would publish for that scene and rate (sample ``k = 0 … floor(S·HZ)`` at stamp
``epoch + k / HZ``). An energy sweep writes every member, member ``j`` under
``NAMESPACE/member_j``.

A scene that takes commands (body torques, wheel torques or speeds, magnetorquers' dipoles) can be
re-simulated under the commands a bag recorded (the node records them, each logged at the sample
it held from): each is offered to the run's hold as if it had arrived at its log time, under the
node's rules, so the samples equal the recorded ones bit for bit. The sensor changes the node
recorded (its ``faults`` and ``sensor_noise`` parameters, ``bag.sensor_changes``) are applied at
the samples they reached in the recording, so its faulted sensor outputs are replayed bit for bit
too.
"""

from __future__ import annotations

import time
from typing import Callable, NamedTuple

import numpy as np

from .cdr import decode_joint_state, decode_stamped_doubles
from .reader import BagReader
from .samples import (
    check_output_frames,
    encode_block,
    encode_command,
    INERTIA_KEY,
    JOINT_STATE,
    resolve_topic,
    sample_qos,
    SampleRecorder,
)
from .sensor_changes import (
    change_text,
    encode_string,
    read_sensor_changes,
    SENSOR_CHANGES,
    STRING,
)
from .writer import BagError, BagWriter
from ..core.checks.validation import finite_vector
from ..core.run.simulation import MAX_STAMP_S, Simulation
from ..core.scene.loader import faults_from_text, noise_from_text
from ..core.timing.grid import sample_count

WRENCH_STAMPED = 'geometry_msgs/msg/WrenchStamped'
VECTOR3_STAMPED = 'geometry_msgs/msg/Vector3Stamped'


class RecordedCommand(NamedTuple):
    log_time_ns: int
    stamp_ns: int
    frame_id: str
    force: np.ndarray
    torque: np.ndarray


class RecordedVectorCommand(NamedTuple):
    log_time_ns: int
    stamp_ns: int
    frame_id: str
    vector: np.ndarray


class RecordedJointCommand(NamedTuple):
    log_time_ns: int
    stamp_ns: int
    frame_id: str
    names: list
    velocity: tuple
    effort: tuple


def _command_reader(bag, topic: str, type_name: str) -> BagReader:
    reader = bag if isinstance(bag, BagReader) else BagReader(bag)
    types = {t.name: t.type_name for t in reader.topics}
    if topic not in types:
        known = ', '.join(sorted(types)) or 'none'
        raise BagError(f"bag '{reader.path}': no topic '{topic}' (topics: {known})")
    if types[topic] != type_name:
        raise BagError(
            f"bag '{reader.path}': topic '{topic}' is {types[topic]}, not {type_name}"
        )
    return reader


def _decoded(bag, topic: str, type_name: str, decode, record) -> list:
    """
    Read a bag's messages of ``topic`` (of ``type_name``), in log-time order, as ``record``s.

    ``decode(data)`` gives the message's fields (``ValueError`` when it is not one),
    ``record(log_time_ns, *fields)`` what is kept of them.
    """
    reader = _command_reader(bag, topic, type_name)
    commands = []
    for message in reader.messages([topic]):
        try:
            fields = decode(message.data)
        except ValueError as error:  # (UnicodeDecodeError too)
            raise BagError(
                f"bag '{reader.path}': a message on '{topic}' at {message.log_time_ns} ns "
                f'is not a {type_name.rsplit("/", 1)[-1]} ({error})'
            ) from None
        commands.append(record(message.log_time_ns, *fields))
    return commands


def read_joint_commands(bag, topic: str) -> list[RecordedJointCommand]:
    """Read a bag's ``sensor_msgs/JointState`` messages of ``topic``, in log-time order."""
    return _decoded(
        bag, topic, JOINT_STATE, decode_joint_state,
        lambda t, stamp, frame, names, _, velocity, effort: RecordedJointCommand(
            t, stamp, frame, names, velocity, effort
        ),
    )


def read_commands(bag, topic: str) -> list[RecordedCommand]:
    """Read a bag's ``geometry_msgs/WrenchStamped`` messages of ``topic``, in log-time order."""
    return _decoded(
        bag, topic, WRENCH_STAMPED, lambda data: decode_stamped_doubles(data, 6),
        lambda t, stamp, frame, values: RecordedCommand(t, stamp, frame, values[:3], values[3:]),
    )


def read_vector_commands(bag, topic: str) -> list[RecordedVectorCommand]:
    """Read a bag's ``geometry_msgs/Vector3Stamped`` messages of ``topic``, in log-time order."""
    return _decoded(
        bag, topic, VECTOR3_STAMPED, lambda data: decode_stamped_doubles(data, 3),
        RecordedVectorCommand,
    )


# samples computed, encoded and written per step at most: memory stays flat at any duration
BLOCK = 4096
FIRST_BLOCK = 1  # the first block's samples; blocks double while one takes under BLOCK_SECONDS
# so a stop (SIGINT, SIGTERM) is seen within about this, however slow a sample is
BLOCK_SECONDS = 0.1
MAX_SAMPLES = 10**10  # per stream: ~1 TB of bag; more is a typo (1e9 s at 1 MHz), refused up front


def member_namespace(namespace: str, index: int) -> str:
    return resolve_topic(f'member_{index}', namespace)


def write_scene_bag(
    scene,
    output,
    duration: float,
    rate: float,
    *,
    epoch_ns: int = 0,
    propagator: str = 'auto',
    body_frame: str = 'body',
    inertial_frame: str = 'world',
    namespace: str = '/',
    overwrite: bool = False,
    compression: str = 'none',
    qos_depth: int = 10,
    progress: Callable[[int, int], None] | None = None,
    stop: Callable[[], bool] | None = None,
    commands_bag=None,
    position=None,
):
    """
    Write samples ``0 … floor(duration·rate)`` of ``scene`` into a bag; return its metadata.

    For a sweep, the samples of each member are written. Everything is checked, and the output
    created, before the first sample is computed. ``progress(samples_done, samples_total)`` is
    called after each block; when ``stop()`` turns true the bag is closed there, complete, with the
    samples written so far. ``commands_bag``: the commands it recorded on each ``torque_command``
    effect's topic, each commanded ``reaction_wheels``' and each ``magnetorquers``' topic (in
    ``namespace``) drive the scene; those logged before ``epoch_ns`` belong to an earlier run and
    are left out. The commands that hold go into the bag too. ``position``:
    where the outputs place the body's centre (x, y, z, m, in the inertial frame; see
    ``encode_block``).
    """
    if position is not None:
        position = finite_vector(position, 'position', (3,))
    count = sample_count(duration, rate)
    if count > MAX_SAMPLES:
        raise ValueError(
            f'duration: {duration:g} s at {rate:g} Hz is {count:.3g} samples; '
            f'at most {MAX_SAMPLES:.0e} (about a terabyte) are written'
        )
    last_stamp_s = epoch_ns / 1e9 + (count - 1) / rate
    if last_stamp_s >= MAX_STAMP_S:
        raise ValueError(
            f'duration: the last stamp would be {last_stamp_s:.6g} s, past what '
            f'builtin_interfaces/Time holds (2^31 s)'
        )
    check_output_frames(scene.outputs, body_frame, inertial_frame)
    members = scene.members()
    namespaces = (
        [member_namespace(namespace, j) for j in range(len(members))]
        if scene.sweep_members
        else [namespace]
    )
    simulations = [
        Simulation(
            member.propagator(propagator),
            rate,
            epoch_ns,
            outputs=scene.outputs,
            faults=scene.faults,
        )
        for member in members
    ]
    retunes = [[] for _ in simulations]  # per simulation: (k, faults, outputs), in order
    if commands_bag is not None:
        for simulation, ns, changes in zip(simulations, namespaces, retunes):
            changes += _sensor_changes(simulation, scene, commands_bag, ns)
            if simulation.command_holds or not changes:
                _drive(simulation, commands_bag, ns, body_frame, inertial_frame)
    custom = {
        'torquefree_ros.scene': scene.source,
        'torquefree_ros.summary': ' | '.join(s.summary() for s in simulations),
        INERTIA_KEY: ' '.join(repr(float(x)) for x in scene.inertia),
    }
    with BagWriter(
        output, overwrite=overwrite, compression=compression, custom_data=custom
    ) as writer:
        recorders = [
            SampleRecorder.in_namespace(writer, ns, sample_qos(qos_depth)) for ns in namespaces
        ]
        total = count * len(simulations)
        first, block_size = 0, FIRST_BLOCK
        while first < count:
            if stop is not None and stop():
                break
            size = min(block_size, count - first)
            # a block ends where a recorded sensor change starts: it applies from its sample
            size = min(
                [size] + [k - first for changes in retunes for k, *_ in changes if k > first]
            )
            started = time.monotonic()
            for simulation, recorder, changes in zip(simulations, recorders, retunes):
                for k, faults, outputs, record in changes:
                    if k == first:
                        simulation.retune(k, faults, outputs)
                        recorder.write_message(
                            SENSOR_CHANGES,
                            STRING,
                            simulation.stamp_ns(k),
                            record,
                        )
                block = simulation.samples(first, size)
                recorder.write_block(
                    block.stamps_ns,
                    encode_block(
                        block, body_frame, inertial_frame, simulation.outputs, position=position
                    ),
                )
                for effect, hold in simulation.command_holds:
                    for command in hold.commands:
                        if first <= command.start < first + size:
                            recorder.write_message(
                                effect.topic,
                                effect.message_type,
                                hold.stamp_ns(command.start),
                                encode_command(command, effect),
                            )
            if progress is not None:
                progress((first + size) * len(simulations), total)
            first += size
            # blocks of the same samples give the same bag content, however they are cut
            if time.monotonic() - started < BLOCK_SECONDS:
                block_size = min(2 * block_size, BLOCK)
            else:
                block_size = max(block_size // 2, 1)
    return writer.metadata


def _sensor_changes(simulation: Simulation, scene, bag, namespace: str) -> list:
    """
    Return the sensor changes a bag recorded for ``simulation``: ``(k, faults, outputs, bytes)``.

    Each applies from the first sample stamped at or after its log time (the sample it reached in
    the recording); those logged before the run's epoch belong to an earlier run. ``outputs``
    are the sensors rebuilt with other noise, by position, as the node rebuilds them.
    """
    reader = bag if isinstance(bag, BagReader) else BagReader(bag)
    topic = resolve_topic(SENSOR_CHANGES, namespace)
    changes, current = [], list(simulation.outputs)
    for change in read_sensor_changes(reader, topic):
        if change.log_time_ns < simulation.epoch_ns:
            continue
        k = _first_sample_stamped(simulation, change.log_time_ns)
        where = f"bag '{reader.path}': {topic} at {change.log_time_ns} ns"
        try:
            rebuilt = noise_from_text(change.sensor_noise, scene.outputs)
            faults = scene.faults + faults_from_text(
                change.faults, scene.outputs, first_index=len(scene.faults)
            )
        except ValueError as error:
            raise BagError(f'{where}: does not fit the scene: {error}') from None
        outputs = {}
        for position, output in enumerate(scene.outputs):
            wanted = rebuilt.get(output.topic, output)
            if wanted != current[position]:
                outputs[position] = current[position] = wanted
        record = encode_string(change_text(change.faults, change.sensor_noise))
        changes.append((k, faults, outputs, record))
    return changes


def _first_sample_stamped(simulation: Simulation, stamp_ns: int) -> int:
    """Return the first sample ``k`` whose stamp is at or after ``stamp_ns``."""
    k = max(0, int((stamp_ns - simulation.epoch_ns) * 1e-9 * simulation.rate))
    while k > 0 and simulation.stamp_ns(k - 1) >= stamp_ns:
        k -= 1
    while simulation.stamp_ns(k) < stamp_ns:
        k += 1
    return k


def _drive(
    simulation: Simulation, bag, namespace: str, body_frame: str, inertial_frame: str
) -> None:
    holds = simulation.command_holds
    if not holds:
        raise ValueError(
            'commands: the scene takes no commands (it names no torque_command effect, no '
            'commanded reaction_wheels and no magnetorquers)'
        )
    for effect, hold in holds:
        hold.frame_id = effect.frame_id(body_frame, inertial_frame)
        topic = resolve_topic(effect.topic, namespace)
        if effect.message_type == JOINT_STATE:
            for joint in read_joint_commands(bag, topic):
                if joint.log_time_ns >= simulation.epoch_ns:
                    effect.receive(
                        joint.stamp_ns,
                        joint.frame_id,
                        joint.names,
                        joint.velocity,
                        joint.effort,
                        arrival_ns=joint.log_time_ns,
                    )
            continue
        if effect.message_type == VECTOR3_STAMPED:
            for vector in read_vector_commands(bag, topic):
                if vector.log_time_ns >= simulation.epoch_ns:
                    effect.receive(
                        vector.stamp_ns,
                        vector.frame_id,
                        vector.vector,
                        arrival_ns=vector.log_time_ns,
                    )
            continue
        for command in read_commands(bag, topic):
            if command.log_time_ns >= simulation.epoch_ns:
                hold.receive(
                    command.stamp_ns,
                    command.torque,
                    command.force,
                    command.frame_id,
                    arrival_ns=command.log_time_ns,
                )
