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
Scenes: a body, its initial state, and the effects and outputs it calls for, read from YAML.

Schema (SI units; every error names the file, the field path and the reason)::

    description: one line                       # optional
    body:                                       # exactly one of:
      inertia: [I1, I2, I3] | [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]
      parts: [- box: {mass, size, position, orientation} | cylinder | sphere | point_mass]
    initial:
      angular_velocity: [wx, wy, wz]           # body frame, rad/s
      orientation: [x, y, z, w]                 # q_NB, default identity
    orbit:                                      # optional: where the body is (core.environment)
      epoch: 2026-03-20T12:00:00Z               # Keplerian elements at a UTC epoch (m, rad) ...
      semi_major_axis: 6878137.0                # eccentricity, inclination, raan,
      j2: true                                  # argument_of_perigee, mean_anomaly; j2 drift
      tle: [line1, line2]                       # ... or a two-line element set (SGP4)
      start: 2026-03-20T13:00:00Z               # the scene's t = 0 (default: the orbit's epoch)
    effects: [- NAME: {parameters}]             # see core.effects; none = torque-free
    faults: [- KIND: {output, start, end, ...}] # optional: faults of the sensor outputs and
                                                # commanded actuators (core.faults.schedule)
    accuracy: 1e-10                             # integrator tolerance when an effect needs one
    sweep: {members: 9}                         # optional: a family at the initial |H| (members())
    watch: 900                                  # optional: seconds its story takes
                                                # (plots show that long)

An effect that changes the motion makes the scene need a numerical propagator; an output effect
(``imu``, ``euler_angles``) only adds a topic. A scene that names nothing builds nothing: no effect
object exists and ``auto`` is the exact solution. An orbit alone changes nothing either: only the
effects and outputs that read the environment (``gravity_gradient``, ``residual_dipole``,
``magnetometer``, ``sun_sensor``, ``orbit``) are placed on it, and they are refused, with their
path, in a scene without one.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
import re

import numpy as np
import yaml

from . import library
from ..body import composite
from ..body.rigid_body import RigidBody
from ..checks.schema import (
    check_keys,
    child,
    FieldError,
    fields,
    integer,
    listing,
    mapping,
    number,
    orientation,
    Param,
    text,
    vector,
)
from ..effects import MotionEffect, OutputEffect, parse_effect
from ..environment.place import Place
from ..faults import check_actuator_faults, parse_faults, parse_noise_changes
from ..propagators import make_propagator, Propagator
from ..propagators.base import overflowing_message, unrepresentable_state
from ..propagators.dynamics import Dynamics
from ...files.safe_files import clip, load_yaml, read_regular_file

DEFAULT_SCENE_DATA = {
    'description': (
        'a triaxial body tumbling visibly about its minor axis (the built-in default scene)'
    ),
    'body': {'inertia': [3.0, 2.0, 1.0]},
    'initial': {'angular_velocity': [0.3, 0.2, 1.0], 'orientation': [0.0, 0.0, 0.0, 1.0]},
    'effects': [],
}
MIN_ACCURACY, MAX_ACCURACY = 1e-14, 1e-3
MAX_WATCH = 3600.0  # s: an hour at 100 Hz is 360 001 samples, about what a plot can show


class SceneError(ValueError):
    """A scene that cannot be used; the message starts with the file and the field path."""


@dataclass(frozen=True)
class Scene:
    inertia: tuple  # 3 principal moments or 6 tensor elements (kg m^2); parts give the tensor
    angular_velocity: tuple  # body frame, rad/s
    orientation: tuple  # q_NB as (x, y, z, w)
    effects: tuple = ()  # MotionEffect instances: they change the motion
    outputs: tuple = ()  # OutputEffect instances: they only add topics
    accuracy: float | None = None  # integrator tolerance; None = the default
    description: str = ''
    source: str = '<built-in default>'
    mass: float | None = None  # kg, for a body made of parts
    center_of_mass: tuple | None = None  # m, in the frame the parts are written in
    sweep_members: int | None = None  # an energy sweep: how many members
    watch: float | None = None  # s: how long the scene must be watched to show what it is about
    orbit: Place | None = None  # where the body is: its orbit and the UTC instant of t = 0
    faults: tuple = ()  # core.faults.Fault instances: what the sensors and actuators suffer, when

    @property
    def torque_free(self) -> bool:
        return not self.effects

    def propagator(
        self,
        name: str = 'auto',
        *,
        inertia=None,
        angular_velocity=None,
        orientation=None,
        **options,
    ) -> Propagator:
        """
        Return the scene's propagator; ``auto`` is exact unless an effect changes the motion.

        The keyword arguments override the scene's body and initial state (the node's parameters).
        """
        return make_propagator(
            self.inertia if inertia is None else inertia,
            self.angular_velocity if angular_velocity is None else angular_velocity,
            self.orientation if orientation is None else orientation,
            name,
            self.effects,
            self.accuracy,
            **options,
        )

    def members(self) -> list['Scene']:
        """
        Return the scenes of the energy sweep (seed 000), or this scene alone without ``sweep``.

        At the ``|H|`` of the initial state, energies are spaced evenly from the minimum
        ``H^2 / (2 I_max)`` (a spin about the major axis) to the maximum ``H^2 / (2 I_min)`` (about
        the minor axis). Member ``j`` has ``H_P = |H| (sqrt(1 - f) e_major + sqrt(f) e_minor)``,
        ``f = j / (members - 1)``, so ``2T = H^2 ((1 - f) / I_max + f / I_min)``. A scene without
        ``sweep`` is its own only member.
        """
        if not self.sweep_members:
            return [self]
        body = RigidBody.from_inertia(self.inertia)
        H = float(body.momentum_magnitude(self.angular_velocity))
        major, minor = int(np.argmax(body.moments)), int(np.argmin(body.moments))
        members = []
        for f in np.linspace(0.0, 1.0, self.sweep_members):
            H_P = np.zeros(3)
            H_P[major], H_P[minor] = H * np.sqrt(1.0 - f), H * np.sqrt(f)
            omega_B = body.principal_axes @ (H_P / body.moments)
            members.append(
                replace(
                    self,
                    angular_velocity=tuple(float(x) for x in omega_B),
                    sweep_members=None,
                    description=f'{self.description} (energy fraction {f:.3g})',
                )
            )
        return members


def default_scene() -> Scene:
    return scene_from_mapping(DEFAULT_SCENE_DATA)


# a scene is a few hundred bytes; a schedule of thousands of segments still fits
MAX_SCENE_BYTES = 1 << 20
MAX_PATH_LENGTH = 4096  # PATH_MAX on Linux


def load_scene(path_or_name) -> Scene:
    """
    Read and validate a scene: a file, or the name of a library scene.

    A library scene is named bare (``explorer1``); ``default`` is the built-in default. An existing
    file wins over a library name. Loading is total: any input gives a Scene or a SceneError naming
    the file (and line, or field path), in bounded time and memory (``safe_files``: regular files
    of at most 1 MiB, bounded YAML).
    """
    name = str(path_or_name)
    if len(name) > MAX_PATH_LENGTH or '\0' in name:
        raise SceneError(
            f'scene: not a usable file name ({len(name)} characters, '
            f'at most {MAX_PATH_LENGTH}, no NUL)'
        )
    path = Path(path_or_name)
    if not _exists(path) and library.is_scene_name(name):
        if name == 'default':
            return default_scene()
        scenes = library.library_scenes()
        if name not in scenes:
            known = ', '.join(sorted(scenes)) or 'none installed'
            raise SceneError(
                f"scene: '{clip(name)}' is neither a file nor a library scene (library: {known})"
            )
        path = scenes[name]
    _, document = read_document(path)
    return scene_from_mapping(document, source=str(path))


def read_document(
    path, error: type[Exception] = SceneError, what: str = 'scene'
) -> tuple[str, object]:
    """
    Read a YAML file as scenes are read; return ``(text, document)``.

    A regular file of at most MAX_SCENE_BYTES, UTF-8, YAML 1.2 numbers, keys given once, bounded
    nesting. Every failure is an ``error`` naming the file (``what`` before a failure to read it at
    all).
    """
    try:
        data = read_regular_file(path, MAX_SCENE_BYTES)
    except OSError as failure:
        raise error(
            f'{what}: cannot read {clip(str(path))!r}: {failure.strerror or failure}'
        ) from None
    except ValueError as failure:
        raise error(f'{what}: {failure}') from None
    try:
        text_ = data.decode('utf-8')
    except UnicodeDecodeError as failure:
        raise error(f'{path}: not UTF-8 text (byte {failure.start})') from None
    try:
        return text_, load_yaml(text_, str(path), _SceneLoader)
    except ValueError as failure:
        raise error(str(failure)) from None


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except (OSError, ValueError):  # a name too long for the file system is not a file
        return False


class _SceneLoader(yaml.SafeLoader):
    """
    The scenes' YAML loader: YAML 1.2 numbers, and a key given twice is an error.

    PyYAML follows YAML 1.1, where ``1e-3`` and ``3.986e14`` (no dot or no exponent sign) are
    strings, a trap in a file of SI values. A key given twice is an error (PyYAML would silently
    keep the last).
    """

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:
                raise yaml.constructor.ConstructorError(
                    None, None, 'a mapping key must be a plain value', key_node.start_mark
                ) from None
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    f'while reading the mapping at line {node.start_mark.line + 1}',
                    node.start_mark,
                    f'duplicate key {clip(repr(key), 60)} (first at line {seen[key].line + 1})',
                    key_node.start_mark,
                )
            seen[key] = key_node.start_mark
        return super().construct_mapping(node, deep=deep)


_SceneLoader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(
        r'^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$'
        r'|^[-+]?\.(?:inf|Inf|INF)$|^\.(?:nan|NaN|NAN)$'
    ),
    list('-+0123456789.'),
)

_INITIAL = {
    'angular_velocity': Param(
        vector(3, unit='rad/s'), description='initial body-frame rate [wx, wy, wz], rad/s'
    ),
    'orientation': Param(orientation(), np.array([0.0, 0.0, 0.0, 1.0])),
}


def scene_from_mapping(data, source: str = '<built-in default>') -> Scene:
    try:
        values = fields(data, '', _TOP)
        values['effects'] = [
            effect.placed(values['orbit'], f'effects[{index}].{effect.name}')
            for index, effect in enumerate(values['effects'])
        ]
        _check_output_topics(values['effects'])
        _check_reported_effects(values['effects'])
        faults = parse_faults(
            values['faults'],
            'faults',
            [effect for effect in values['effects'] if isinstance(effect, OutputEffect)],
        )
        check_actuator_faults(faults, values['effects'])
        rigid_body = RigidBody.from_inertia(values['body']['inertia'])
        _check_state_scale(rigid_body, values)
        _check_effect_scales(rigid_body, values)
    except FieldError as error:
        raise SceneError(f'{source}: {error}') from None
    body, initial, effects = values['body'], values['initial'], values['effects']
    return Scene(
        inertia=body['inertia'],
        angular_velocity=tuple(float(x) for x in initial['angular_velocity']),
        orientation=tuple(float(x) for x in initial['orientation']),
        effects=tuple(e for e in effects if isinstance(e, MotionEffect)),
        outputs=tuple(e for e in effects if isinstance(e, OutputEffect)),
        accuracy=values['accuracy'],
        description=values['description'],
        source=source,
        mass=body.get('mass'),
        center_of_mass=body.get('center_of_mass'),
        sweep_members=values['sweep']['members'] if values['sweep'] else None,
        watch=values['watch'],
        orbit=values['orbit'],
        faults=faults,
    )


def faults_from_text(text_: str, outputs, first_index: int = 0, name: str = 'faults') -> tuple:
    """
    Read a YAML (or JSON) list of faults as a scene's ``faults:`` against ``outputs``.

    Empty text is none; ``first_index`` numbers the first (its draws' key: after the scene's).
    Errors are ``ValueError`` naming ``name`` and the field path (``faults[0].bias.step: ...``):
    the node's ``faults`` parameter.
    """
    return parse_faults(_parameter_document(text_, name, []), name, outputs, first_index)


def noise_from_text(text_: str, outputs, name: str = 'sensor_noise') -> dict:
    """
    Read a YAML (or JSON) mapping ``{TOPIC: {PARAMETER: value}}`` of sensor noise changes.

    Return ``{topic: the rebuilt output}`` (``core.faults.parse_noise_changes``); errors name
    ``name`` and the field path.
    """
    return parse_noise_changes(_parameter_document(text_, name, {}), name, outputs)


def _parameter_document(text_: str, name: str, empty):
    """Read a parameter's YAML text as a scene file's (YAML 1.2 numbers, bounded); ``empty``."""
    if not text_.strip():
        return empty
    document = load_yaml(text_, name, _SceneLoader)  # ValueError: 'NAME:LINE:COLUMN: ...'
    return empty if document is None else document


def _check_state_scale(body: RigidBody, values) -> None:
    """
    Check that the body at its initial rates stays within float64, by the propagators' own rule.

    A rate such as ``[1e154, 0, 0]`` is refused here, with its path, not when a propagator is
    built.
    """
    problem = unrepresentable_state(body, values['initial']['angular_velocity'])
    if problem is not None:
        raise FieldError('initial.angular_velocity', problem)


def _check_effect_scales(body: RigidBody, values) -> None:
    """
    Check that each motion effect's torque and state rate at the initial state are finite.

    A parameter such as ``mean_motion: 1e308`` is refused here, with its path, not mid-run.
    """
    initial = values['initial']
    omega = np.asarray(initial['angular_velocity'], dtype=float)
    q = np.asarray(initial['orientation'], dtype=float)
    for index, effect in enumerate(values['effects']):
        if isinstance(effect, MotionEffect):
            dynamics = Dynamics(body, [effect.bound(body.tensor)])
            if dynamics.overflowing_effect(omega, q, dynamics.initial_state(omega)) is not None:
                raise FieldError(
                    f'effects[{index}].{effect.name}',
                    overflowing_message(effect).split(': ', 1)[1],
                )


_SAMPLE_TOPICS = ('angular_velocity', 'attitude', '/clock', '/diagnostics')


def _command_topic(effect) -> str | None:
    """Return the topic an effect takes commands on (``commanded``), or None."""
    return effect.topic if isinstance(effect, MotionEffect) and effect.commanded else None


def _check_output_topics(effects) -> None:
    """
    Refuse two effects on one topic, and an output on one of the simulator's own.

    Each topic has one meaning: an output's messages, or one commanded effect's commands (every
    command names only that effect's wheels or rods, so two arrays sharing a topic would refuse
    each other's commands; arrays in different modes take a topic each).
    """
    used = {}
    for index, effect in enumerate(effects):
        if isinstance(effect, OutputEffect):
            topic = effect.topic
        else:
            topic = _command_topic(effect)
            if topic is None:
                continue
        where = f'effects[{index}].{effect.name}.topic'
        if topic in _SAMPLE_TOPICS:
            raise FieldError(where, f"'{topic}' is one of the simulator's own topics")
        if topic in used:
            raise FieldError(where, f"'{topic}' is already the topic of effects[{used[topic]}]")
        used[topic] = index


def _check_reported_effects(effects) -> None:
    """Refuse an output that reports on an effect the scene lacks (``wheel_states``' wheels)."""
    names = {effect.name for effect in effects}
    for index, effect in enumerate(effects):
        needed = getattr(effect, 'reports_on', None)
        if needed is not None and needed not in names:
            raise FieldError(
                f'effects[{index}].{effect.name}',
                f'reports on a {needed} effect, and the scene has none',
            )


def _body(value, path: str) -> dict:
    if not isinstance(value, dict):
        raise FieldError(path, "expected a mapping with 'inertia' or 'parts'")
    check_keys(value, ('inertia', 'parts'), path)
    if ('inertia' in value) == ('parts' in value):
        raise FieldError(
            path, "give either 'inertia' or 'parts', not " + ('both' if value else 'neither')
        )
    if 'inertia' in value:
        where = child(path, 'inertia')
        inertia = vector(3, 6, unit='kg m^2')(value['inertia'], where)
        _check_inertia(inertia, where)
        return {'inertia': tuple(float(x) for x in inertia)}
    where = child(path, 'parts')
    body = composite.combine(listing(composite.parse_part, min_length=1)(value['parts'], where))
    _check_inertia(body.tensor, where)
    return {
        'inertia': composite.tensor_elements(body.tensor),
        'mass': body.mass,
        'center_of_mass': tuple(float(x) for x in body.center_of_mass),
    }


_TOP = {
    'description': Param(text(allow_empty=True), ''),
    'body': Param(_body, description='every scene names its body: inertia or parts'),
    'initial': Param(mapping(_INITIAL), description='every scene names its initial state'),
    'orbit': Param(Place.from_mapping, None),
    'effects': Param(listing(parse_effect), []),
    # checked against the outputs once they are read (scene_from_mapping)
    'faults': Param(lambda value, path: value, []),
    'accuracy': Param(number(MIN_ACCURACY, MAX_ACCURACY), None),
    'sweep': Param(
        mapping(
            {'members': Param(integer(2, 1000), description='how many initial states, 2 or more')}
        ),
        None,
    ),
    'watch': Param(number(positive=True, maximum=MAX_WATCH, unit='s'), None),
}


def _check_inertia(inertia, path: str) -> None:
    try:
        RigidBody.from_inertia(inertia, 'inertia')
    except ValueError as error:
        raise FieldError(path, str(error).split(': ', 1)[-1]) from None
