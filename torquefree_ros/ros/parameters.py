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
The simulator node's parameters: declarations, validation and the configuration they describe.

Each parameter is declared with a descriptor. Values take effect at the next ``~/reset``
(``qos_depth`` only at start-up); ``faults`` and ``sensor_noise`` also at the next sample of the
running run (:func:`sensor_changes`).

Every parameter is declared with dynamic typing so that this module, not rclpy, checks the type:
the reason then names the parameter, and an integer is accepted where a number is meant
(``publish_rate: 100`` in YAML).
"""

from __future__ import annotations

from dataclasses import dataclass
import os
from pathlib import Path
import re

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.parameter import Parameter

from .guarded_parameters import refusal
from .qos import message_class
from .sample_loop import RunRequest, SensorChanges
from ..bag.samples import check_output_frames
from ..bag.sensor_changes import change_text
from ..core import PROPAGATORS
from ..core.body.rigid_body import RigidBody
from ..core.checks.schema import shown
from ..core.checks.validation import finite_vector, unit_quaternion
from ..core.faults import check_actuator_faults
from ..core.propagators import MAX_STEPS_PER_SAMPLE
from ..core.run.simulation import Simulation
from ..core.scene.library import is_scene_name, library_scenes
from ..core.scene.loader import (
    default_scene,
    faults_from_text,
    load_scene,
    MAX_PATH_LENGTH,
    MAX_SCENE_BYTES,
    noise_from_text,
    SceneError,
)
from ..core.timing.grid import check_rate, MAX_RATE, MIN_RATE
from ..files.safe_files import clip

_NUMBER = (Parameter.Type.INTEGER, Parameter.Type.DOUBLE)
_ARRAY = (Parameter.Type.INTEGER_ARRAY, Parameter.Type.DOUBLE_ARRAY, Parameter.Type.BYTE_ARRAY)
MAX_REAL_TIME_FACTOR = 1e6


class ConfigurationError(ValueError):
    """The parameters do not describe a usable simulation; the message names the parameter."""


@dataclass(frozen=True)
class ParameterSpec:
    name: str
    default: object  # None: not set (the scene's value is used)
    description: str
    constraints: str
    read_only: bool = False
    number_range: tuple | None = None

    def descriptor(self) -> ParameterDescriptor:
        descriptor = ParameterDescriptor(
            description=self.description,
            additional_constraints=self.constraints,
            read_only=self.read_only,
            dynamic_typing=True,
        )
        if self.number_range is not None:
            low, high = self.number_range
            if isinstance(low, int) and isinstance(high, int):
                descriptor.integer_range = [IntegerRange(from_value=low, to_value=high, step=0)]
            else:
                descriptor.floating_point_range = [
                    FloatingPointRange(from_value=low, to_value=high, step=0.0)
                ]
        return descriptor


_AT_RESET = ' Takes effect at the next ~/reset.'
MAX_FRAME_LENGTH = 256
# tf2 and REP 105 frame ids: letters, digits, '_', '-', '.', '/' separating names, no leading '/'
_FRAME = re.compile(r'^[A-Za-z0-9_.\-]+(/[A-Za-z0-9_.\-]+)*$')
_FRAME_CHARACTERS = "letters, digits, '_', '-', '.', and '/' between names; no leading '/'"
_FRAME_RULE = f'1 to {MAX_FRAME_LENGTH} characters: {_FRAME_CHARACTERS}'
_PREFIX_RULE = (
    f"empty, or the start of a frame id ({_FRAME_CHARACTERS}), e.g. 'sat1/' or 'sat1_'; "
    f'with body_frame at most {MAX_FRAME_LENGTH} characters'
)
SPECS = (
    ParameterSpec(
        'scene',
        '',
        'Path of a scene file (YAML), or the name of a library scene (dzhanibekov, explorer1, '
        '...); empty = the built-in default scene. Once running, only library names, the start-up '
        'scene and files under scene_directories are accepted.' + _AT_RESET,
        'a library scene name, the start-up scene, or a regular file of at most 1 MiB under '
        'scene_directories; or empty',
    ),
    ParameterSpec(
        'scene_directories',
        [''],
        "Directories whose scene files (and subdirectories') the scene parameter may name while "
        "the node runs; read at start-up only, so no participant on the domain can widen it. [''] "
        '= none (library names and the start-up scene only).',
        'absolute or relative directory paths',
        read_only=True,
    ),
    ParameterSpec(
        'inertia',
        None,
        'Principal moments [I1, I2, I3] or tensor [Ixx, Iyy, Izz, Ixy, Ixz, Iyz], kg m^2; '
        "overrides the scene; not set or [] = the scene's." + _AT_RESET,
        '3 or 6 finite numbers; positive-definite; moments obey the triangle inequality',
    ),
    ParameterSpec(
        'angular_velocity',
        None,
        'Initial body-frame angular velocity [wx, wy, wz], rad/s; overrides the scene; '
        "not set or [] = the scene's." + _AT_RESET,
        '3 finite numbers',
    ),
    ParameterSpec(
        'orientation',
        None,
        'Initial attitude q_NB (x, y, z, w), body to inertial; overrides the scene; '
        "not set or [] = the scene's; normalised when |q|^2 is within 0.01 of 1 (tf2's rule)."
        + _AT_RESET,
        '4 finite numbers, |q|^2 within 0.01 of 1',
    ),
    ParameterSpec(
        'sweep_member',
        -1,
        'For an energy-sweep scene (energy_sweep): the member to run, 0 = minimum energy; -1 = '
        "the scene's own initial state." + _AT_RESET,
        'an integer in [-1, members - 1]',
        number_range=(-1, 999),
    ),
    ParameterSpec(
        'publish_rate',
        100.0,
        'Samples per simulated second, Hz; sample k is the state at k / rate.' + _AT_RESET,
        f'>= {MIN_RATE:g} and <= {MAX_RATE:g}',
        number_range=(MIN_RATE, MAX_RATE),
    ),
    ParameterSpec(
        'real_time_factor',
        1.0,
        '1 = wall-clock pace with wall-clock stamps; other values pace simulated time at this '
        'multiple of wall time and publish /clock; 0 = as fast as possible.' + _AT_RESET,
        f'>= 0 and <= {MAX_REAL_TIME_FACTOR:g}',
        number_range=(0.0, MAX_REAL_TIME_FACTOR),
    ),
    ParameterSpec(
        'publish_clock',
        False,
        'Publish /clock at real_time_factor 1 too: one message per sample, at its stamp, just '
        'before it, so that neighbours started with use_sim_time:=true follow the simulator (they '
        'wait forever for a /clock otherwise). Any other real_time_factor, or lockstep, always '
        'publishes /clock.' + _AT_RESET,
        'true or false',
    ),
    ParameterSpec(
        'body_frame',
        'body',
        'header.frame_id of angular_velocity (the body frame).' + _AT_RESET,
        _FRAME_RULE,
    ),
    ParameterSpec(
        'inertial_frame',
        'world',
        'header.frame_id of attitude (the inertial frame).' + _AT_RESET,
        _FRAME_RULE,
    ),
    ParameterSpec(
        'frame_prefix',
        '',
        "Put before body_frame wherever the body frame is named (angular_velocity, /tf's child, "
        'the outputs, the frame of body-frame commands), not before inertial_frame: nodes in '
        'several namespaces then publish distinct bodies (sat1/body, sat2/body) under one shared '
        'inertial frame on /tf. Empty = none.' + _AT_RESET,
        _PREFIX_RULE,
    ),
    ParameterSpec(
        'position',
        [0.0, 0.0, 0.0],
        "Where the body's centre sits in the inertial frame [x, y, z], m: /tf's translation, the "
        "position of pose and odometry, the markers' place. Constant (the simulator moves "
        'attitude only); for several bodies side by side in one view. [] = the origin.'
        + _AT_RESET,
        '3 finite numbers',
    ),
    ParameterSpec(
        'propagator',
        'auto',
        "auto (the exact solution for a torque-free scene, DOP853 at the scene's accuracy when an "
        'effect changes the motion) or a registered propagator.' + _AT_RESET,
        'one of: ' + ', '.join(['auto', *sorted(PROPAGATORS)]),
    ),
    ParameterSpec(
        'qos_depth',
        10,
        "History depth of the reliable publishers (/tf at least 100, as tf2_ros's broadcaster) "
        'and of the best-effort command inputs (read at start-up only).',
        'an integer in [1, 10000]',
        read_only=True,
        number_range=(1, 10000),
    ),
    ParameterSpec(
        'lockstep',
        False,
        'Closed loop in lock-step (read at start-up only): after publishing sample k the node '
        "waits for the controller's commands (torque_command, wheel_command: each the scene "
        'takes) stamped t_k (or later), applies them over [t_k, t_k+1), then computes sample '
        'k+1; so the same controller gives the same samples whatever the load. Runs on a clock '
        'of its own (/clock); real_time_factor then only caps the pace (0 = as fast as the '
        'controller answers).',
        'true or false',
        read_only=True,
    ),
    ParameterSpec(
        'lockstep_timeout',
        1.0,
        "Lock-step: wall seconds to wait for the controller's answer before going on with the "
        'command in force (counted as a missed step in /diagnostics).' + _AT_RESET,
        '> 0 and <= 3600',
        number_range=(0.0, 3600.0),
    ),
    ParameterSpec(
        'faults',
        '',
        "Faults of the sensor outputs and actuators, added to the scene's: a YAML or JSON list "
        "as a scene's faults: (- KIND: {output, start, end, ...}; KIND stuck, bias, noise, "
        'spikes or dropout; or wheel_stuck: {wheel, start, end}, magnetorquer_stuck: {start, '
        'end, value}; start and end in s of the run). Takes effect at the next sample (a window '
        'that started before starts there) and at each ~/reset; recorded in the bag. Empty = '
        'none.',
        "a list of faults naming the running scene's sensor outputs by topic, its commanded "
        'wheels by name',
    ),
    ParameterSpec(
        'sensor_noise',
        '',
        "The sensors' noise parameters changed from the scene's: a YAML or JSON mapping {TOPIC: "
        "{PARAMETER: value}} in the scene's units (imu: angle_random_walk, gyro_noise_density, "
        'rate_random_walk, gyro_bias_random_walk, bias_instability, bias_correlation_time; '
        'star_tracker: cross_boresight_noise, about_boresight_noise; magnetometer, sun_sensor: '
        'noise). Takes effect at the next sample and at each ~/reset; recorded in the bag. '
        "Empty = the scene's.",
        "a mapping naming the running scene's sensor outputs by topic",
    ),
    ParameterSpec(
        'record_bag',
        '',
        'Bag directory (rosbag2 MCAP) to record every published sample into; empty = no '
        'recording. Read at start-up only, so no participant on the domain can make the node '
        'write elsewhere.',
        'a path that does not exist yet, in a writable directory; an existing bag is never '
        'overwritten',
        read_only=True,
    ),
)
SPEC_BY_NAME = {spec.name: spec for spec in SPECS}


def check_value(name: str, parameter: Parameter):
    """Return the parameter's value in canonical form; ``ValueError`` names it and the reason."""
    kind, value = parameter.type_, parameter.value
    if name == 'scene_directories':
        if kind != Parameter.Type.STRING_ARRAY:
            raise ValueError(
                f'{name}: expected an array of strings, got {_type_name(kind)} {shown(value)}'
            )
        return tuple(v for v in value if v)
    if kind == Parameter.Type.NOT_SET:
        if SPEC_BY_NAME[name].default is None:
            return None
        raise ValueError(f'{name}: cannot be unset')
    if name in ('inertia', 'angular_velocity', 'orientation'):
        if kind not in _ARRAY:
            raise ValueError(
                f'{name}: expected an array of numbers, got {_type_name(kind)} {shown(value)}'
            )
        if len(value) == 0:
            return None  # the scene's value
        if kind == Parameter.Type.BYTE_ARRAY:
            raise ValueError(f'{name}: expected an array of numbers, got a byte array')
        if name == 'inertia':
            RigidBody.from_inertia(value, name)
            return tuple(float(x) for x in value)
        if name == 'angular_velocity':
            return tuple(finite_vector(value, name, (3,)).tolist())
        return tuple(unit_quaternion(value, name).tolist())
    if name == 'position':
        if kind not in _ARRAY or kind == Parameter.Type.BYTE_ARRAY:
            raise ValueError(
                f'{name}: expected an array of 3 numbers, got {_type_name(kind)} {shown(value)}'
            )
        return tuple(finite_vector(value, name, (3,)).tolist()) if len(value) else (0.0, 0.0, 0.0)
    if name in ('lockstep', 'publish_clock'):
        if kind != Parameter.Type.BOOL:
            raise ValueError(
                f'{name}: expected true or false, got {_type_name(kind)} {shown(value)}'
            )
        return bool(value)
    if name in (
        'publish_rate',
        'real_time_factor',
        'qos_depth',
        'sweep_member',
        'lockstep_timeout',
    ):
        integral = name in ('qos_depth', 'sweep_member')
        if kind not in _NUMBER or (integral and kind != Parameter.Type.INTEGER):
            wanted = 'an integer' if integral else 'a number'
            raise ValueError(f'{name}: expected {wanted}, got {_type_name(kind)} {shown(value)}')
        if name == 'publish_rate':
            return check_rate(value, name)
        if name == 'real_time_factor':
            if not 0.0 <= float(value) <= MAX_REAL_TIME_FACTOR:
                raise ValueError(
                    f'{name}: must lie in [0, {MAX_REAL_TIME_FACTOR:g}], got {shown(value)}'
                )
            return float(value)
        if name == 'lockstep_timeout':
            if not 0.0 < float(value) <= 3600.0:
                raise ValueError(f'{name}: must lie in (0, 3600] s, got {shown(value)}')
            return float(value)
        if name == 'sweep_member':
            if not -1 <= value <= 999:
                raise ValueError(f'{name}: must lie in [-1, 999], got {shown(value)}')
            return int(value)
        if not 1 <= value <= 10000:
            raise ValueError(f'{name}: must lie in [1, 10000], got {shown(value)}')
        return int(value)
    if name in ('faults', 'sensor_noise') and kind in (*_ARRAY, Parameter.Type.BOOL_ARRAY):
        if len(value) == 0:  # `ros2 param set NODE faults "[]"` sends an empty array: none
            return ''
    if kind != Parameter.Type.STRING:
        raise ValueError(f'{name}: expected a string, got {_type_name(kind)} {shown(value)}')
    if name in ('faults', 'sensor_noise'):
        if len(value) > MAX_SCENE_BYTES:
            raise ValueError(
                f"{name}: at most {MAX_SCENE_BYTES} characters (a scene file's bound), "
                f'got {len(value)}'
            )
        return value  # checked against the scene's outputs by run_request and sensor_changes
    if name in ('scene', 'record_bag'):
        if len(value) > MAX_PATH_LENGTH or '\0' in value:
            raise ValueError(
                f'{name}: expected a path of at most {MAX_PATH_LENGTH} characters without NUL, '
                f'got {len(value)} characters'
            )
        return value
    if name == 'propagator':
        if value != 'auto' and value not in PROPAGATORS:
            known = ', '.join(['auto', *sorted(PROPAGATORS)])
            raise ValueError(f'{name}: unknown propagator {shown(value)} (known: {known})')
        return value
    if name == 'frame_prefix':
        # a prefix is a frame id's start: whatever frame follows it, "x" or "body", the whole
        # is one
        if value and (len(value) >= MAX_FRAME_LENGTH or not _FRAME.match(value + 'x')):
            raise ValueError(f'{name}: expected {_PREFIX_RULE}, got {shown(value)}')
        return value
    if len(value) > MAX_FRAME_LENGTH or not _FRAME.match(value):
        raise ValueError(f'{name}: expected a frame id of {_FRAME_RULE}, got {shown(value)}')
    return value


class ScenePolicy:
    """
    Which scene files a remote caller may name, fixed at start-up.

    Library names, the start-up scene and regular files below ``directories`` (symbolic links
    resolved first, so a link cannot lead out). Anything else is refused without reading it, so no
    refusal quotes a file it should not.
    """

    def __init__(self, start_up_scene: str, directories):
        self.start_up = start_up_scene
        self.directories = tuple(Path(os.path.realpath(d)) for d in directories if d)

    def check(self, scene: str) -> None:
        if (
            not scene
            or scene == self.start_up
            or (is_scene_name(scene) and scene in {*library_scenes(), 'default'})
        ):
            return
        try:
            real = Path(os.path.realpath(scene))
        except (OSError, ValueError):
            real = None
        if real is not None and any(real.is_relative_to(d) for d in self.directories):
            return
        where = ', '.join(str(d) for d in self.directories) or 'none given'
        library = ', '.join(sorted(library_scenes()))
        raise ValueError(
            f'scene: {shown(scene)} is not a library scene ({library}) '
            f'nor a file under scene_directories ({where}; set at start-up)'
        )


_OVERRIDES = ('inertia', 'angular_velocity', 'orientation')


def run_request(values: dict) -> RunRequest:
    """
    Build the run that canonical values (``check_value``) describe.

    The scene fills what is not set. Building its propagator checks that the whole state is
    usable, not only each value alone.
    """
    try:
        scene = load_scene(values['scene']) if values['scene'] else default_scene()
    except SceneError as error:
        message = str(error)
        raise ValueError(
            message if message.startswith('scene:') else f'scene: {message}'
        ) from None
    member = values['sweep_member']
    if member >= 0:
        if not scene.sweep_members:
            raise ValueError(
                f'sweep_member: {member} given, but the scene is not an energy sweep (use -1)'
            )
        clashing = [key for key in ('inertia', 'angular_velocity') if values[key] is not None]
        if clashing:
            raise ValueError(
                'sweep_member: the member defines the body and its rate, so it cannot be '
                f'combined with {" or ".join(clashing)} (set {clashing[0]} to [] first)'
            )
        if member >= scene.sweep_members:
            raise ValueError(
                f'sweep_member: the scene has members 0 … {scene.sweep_members - 1}, got {member}'
            )
        scene = scene.members()[member]
    # an output whose message type this Python lacks (tf2_msgs from PyPI) is left out, and said so
    scene_outputs = tuple(output for output in scene.outputs if _installed(output.message_type))
    rebuilt = noise_from_text(values['sensor_noise'], scene_outputs)
    outputs = tuple(rebuilt.get(output.topic, output) for output in scene_outputs)
    faults = scene.faults + faults_from_text(
        values['faults'], scene_outputs, first_index=len(scene.faults)
    )
    missing = [
        f'{output.name} ({output.message_type})'
        for output in scene.outputs
        if output not in scene_outputs
    ]
    propagator = scene.propagator(
        values['propagator'],
        inertia=values['inertia'],
        angular_velocity=values['angular_velocity'],
        orientation=values['orientation'],
    )
    propagator.max_steps_per_sample = MAX_STEPS_PER_SAMPLE
    # the first sample period, computed now: a scene too stiff (or too many steps per sample) or
    # outside float64 fails here, with its reason, rather than in the sample loop after the run
    # was accepted
    try:
        Simulation(
            propagator,
            values['publish_rate'],
            rate_name='publish_rate',
            outputs=outputs,
            faults=faults,
        ).samples(0, 2)
    except RuntimeError as error:
        raise ValueError(f'propagator: {error}') from None
    left_out = ''
    if missing:
        left_out = (
            f'not published: {", ".join(missing)} (its message package is not installed here; '
            'every ROS 2 install has it, and torquefree_bag writes it to bags without it)'
        )
    body_frame = values['frame_prefix'] + values['body_frame']
    if len(body_frame) > MAX_FRAME_LENGTH:
        raise ValueError(
            f"frame_prefix: with body_frame '{clip(values['body_frame'], 40)}' the body frame has "
            f'{len(body_frame)} characters, at most {MAX_FRAME_LENGTH} are allowed'
        )
    check_output_frames(outputs, body_frame, values['inertial_frame'])
    return RunRequest(
        propagator,
        values['publish_rate'],
        values['real_time_factor'],
        body_frame,
        values['inertial_frame'],
        outputs,
        describe(values, scene),
        left_out,
        values['lockstep'],
        values['lockstep_timeout'],
        values['publish_clock'],
        values['position'],
        SensorChanges(
            faults,
            scene.faults,
            scene_outputs,
            change_text(values['faults'], values['sensor_noise'])
            if values['faults'] or values['sensor_noise']
            else '',
        ),
    )


def sensor_changes(values: dict, request: RunRequest, simulation) -> SensorChanges:
    """
    Return what the ``faults`` and ``sensor_noise`` of ``values`` change in the running run.

    Checked against the running run's scene (``request``), which the next ``~/reset`` may
    replace: ``ValueError`` names the parameter and the field path. ``outputs`` are the sensors
    to rebuild, by position: those whose parameters differ from what ``simulation`` runs.
    """
    sensors = request.sensors
    rebuilt = noise_from_text(values['sensor_noise'], sensors.scene_outputs)
    outputs = {}
    for position, (running, scene_output) in enumerate(
        zip(simulation.outputs, sensors.scene_outputs)
    ):
        wanted = rebuilt.get(scene_output.topic, scene_output)
        if wanted != running:
            outputs[position] = wanted
    faults = sensors.scene_faults + faults_from_text(
        values['faults'], sensors.scene_outputs, first_index=len(sensors.scene_faults)
    )
    check_actuator_faults(faults, simulation.propagator.effects)
    record = (
        change_text(values['faults'], values['sensor_noise'])
        if values['faults'] or values['sensor_noise'] or sensors.record
        else ''
    )
    return SensorChanges(faults, sensors.scene_faults, sensors.scene_outputs, record, outputs)


def _installed(type_name: str) -> bool:
    try:
        message_class(type_name)
        return True
    except ValueError:
        return False


def describe(values: dict, scene) -> str:
    """
    Describe the run: what a user needs to know to reproduce it.

    ``scene 'dzhanibekov' (FILE), overrides: inertia [..]`` — what a user needs to know to
    reproduce the run, including parameters that stay in force after the scene changed.
    """
    name = (
        f"scene '{values['scene']}' ({scene.source})"
        if values['scene']
        else 'the built-in default scene'
    )
    if values['sweep_member'] >= 0:
        energy = scene.description.rsplit('(', 1)[-1].rstrip(')')
        name += f' member {values["sweep_member"]} ({energy})'
    overrides = [
        f'{key} [{", ".join(f"{x:.9g}" for x in values[key])}]'
        for key in _OVERRIDES
        if values[key] is not None
    ]
    return f'{name}, overrides: {"; ".join(overrides) if overrides else "none"}'


def rejection(error: ValueError) -> SetParametersResult:
    return refusal(str(error))


def _type_name(kind: Parameter.Type) -> str:
    return kind.name.lower().replace('_', ' ')
