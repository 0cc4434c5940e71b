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
The faults of sensor outputs and actuators: their kinds, their fields and where each acts.

A fault is a one-key mapping ``- KIND: {output, start, end, ...}`` (as effects are named)::

    - stuck:   {output: imu, start: 2.0, end: 4.0}                # at the last value, or
    - stuck:   {output: imu, start: 2.0, value: [0.0, 0.0, 0.1]}  # at a given value
    - bias:    {output: magnetometer, start: 1.0, step: [1e-6, 0.0, 0.0]}
    - noise:   {output: star_tracker, start: 0.0, end: 9.0, sigma: 1e-4}
    - spikes:  {output: imu, start: 0.0, magnitude: 0.5, probability: 0.01}   # or period: s
    - dropout: {output: sun_sensor, start: 3.0, end: 3.5}

``output`` is the output's topic (its name unless the scene gives it a ``topic``), one of the
sensors in :data:`FAULTED_OUTPUTS`. ``start`` and ``end`` are seconds of the run (``end`` left
out: until the run ends); the fault acts on the output's samples ``j`` (on its own grid, ``t_j = j
/ rate``) from the first at or after ``start`` to the last before the first at or after ``end``
(:func:`~torquefree_ros.core.timing.grid.first_sample_at_or_after`, the one rule).

What each kind does (SI values, in the output's unit: rad/s for the ``imu``, T for the
``magnetometer``, a rotation vector in rad, body frame, for the ``star_tracker`` and the
``sun_sensor``):

* ``stuck``: the output repeats the row it read at the sample before the window (its first sample
  when the window starts at sample 0), measurement and covariance together, or, with ``value``,
  carries that value in its measurement (a unit quaternion ``(x, y, z, w)`` for the star tracker);
* ``bias``: ``step`` is added to the measurement (vectors), or the measurement is turned by it
  (``q ⊗ exp(step / 2)``, ``R(exp(step)) v``);
* ``noise``: an added white noise of 1-sigma ``sigma`` per axis, the same way (the sensor's own
  noise is not scaled: the sensor computes its rows whole, so a fault sees only them);
* ``spikes``: on a sample with a spike, ``magnitude`` along a random direction, the same way; a
  spike on each sample with ``probability``, or on the first sample at or after ``start + n
  period``;
* ``dropout``: no message at all.

The actuators' faults (:data:`ACTUATOR_FAULTS`) act on the inputs a commanded effect holds, not
on rows, on the run's own samples ``k`` (``t_k = k / rate``, the same rule) and the intervals
``[t_k, t_k+1)`` they start (:mod:`.actuators`)::

    - wheel_stuck:        {wheel: rw1, start: 2.0, end: 4.0}   # no motor torque: friction only
    - magnetorquer_stuck: {start: 2.0, end: 4.0}               # at the last dipole, or
    - magnetorquer_stuck: {start: 2.0, value: [0.1, 0.0, 0.0]} # at a given one, A m^2
    - torque_stuck:       {start: 1.0, end: 3.0}               # at the last torque, or
    - torque_stuck:       {start: 1.0, value: [0.0, 0.0, 0.0]} # at a given one, N m
    - torque_error:       {start: 1.0, bias: [1e-3, 0.0, 0.0], scale: 0.8}
    - torque_noise:       {start: 1.0, end: 3.0, sigma: 1e-4, seed: 7}  # N m, 1-sigma an axis
    - wheel_torque_error: {wheel: rw1, start: 2.0, bias: 1e-3, scale: 0.5}
    - wheel_torque_noise: {wheel: rw1, start: 2.0, sigma: 1e-4}        # N m, 1-sigma
    - dipole_noise:       {start: 0.0, sigma: [0.01, 0.01, 0.02]}      # A m^2, 1-sigma an axis

* ``wheel_stuck``: the wheel named (a wheel of commanded ``reaction_wheels``) ignores commands and
  its drive is off: its input is the one it has with no command in force (zero torque; a speed
  drive off), so friction alone acts on it;
* ``magnetorquer_stuck``: every ``magnetorquers`` effect holds the dipole it was asked for on the
  interval before the window (zero when the window starts at sample 0 or no command was in
  force), or ``value``, through the rods' saturation as any command: ``value: [0, 0, 0]`` turns
  them off;
* ``torque_stuck``: the ``torque_command`` effect holds the torque it held on the interval
  before the window (zero when none was in force), or ``value`` (N m, in the effect's frame);
* ``torque_error``: the ``torque_command`` effect's torque (in its frame) is ``scale * torque +
  bias`` (``scale`` a number or one per axis, default 1; ``bias`` N m, default zero), whatever
  holds: a command, or zero once it timed out;
* ``torque_noise``, ``wheel_torque_noise``, ``dipole_noise``: a seeded white noise of 1-sigma
  ``sigma`` (a number, or one per axis for the torque and the dipole) is added to what holds on
  each interval (the ``torque_command``'s torque in its frame, whatever holds; the motor torque
  asked of the wheel named, of ``reaction_wheels`` in mode ``torque``, before its limits; every
  ``magnetorquers``' dipole asked, before the rods' saturation); its normals are those of the
  sensors' ``noise`` fault (:mod:`.draws`: keyed by ``seed``, default 0, and the fault's place in
  its list, at the run's sample ``k``), so live, offline, a replay and the plant add the same;
* the torque faults (``torque_stuck``, ``torque_error``, ``torque_noise``) act on the
  ``torque_command`` on their ``topic``: given, or the scene's only one (every one on that topic);
* ``wheel_torque_error``: the motor torque asked of the wheel named (of ``reaction_wheels`` in
  mode ``torque``; in mode ``speed`` the speed loop's output ``u = Js speed_bandwidth (Omega_ref
  - Omega)``, zero with the drive off) is ``scale * u + bias`` (N m; default 1 and 0), before the
  wheel's torque and speed limits, which still bound what the motor applies.

A stuck or a given value replaces what the faults before it in the list did; an error acts on
what they left (faults on one input apply in list order).

A row that carries no measurement (a gyro's or star tracker's latency start, a star tracker with
no solution, a sun sensor without the Sun) stays as it is under bias, noise and spikes. Faults of
one output apply in list order; ``stuck`` replaces what the faults before it did, ``dropout``
removes the message whatever the others do.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

from ..checks.schema import (
    child,
    FieldError,
    fields,
    integer,
    listing,
    number,
    one_key,
    Param,
    shown,
    text,
    vector,
)
from ..checks.validation import unit_quaternion
from ..timing.grid import first_sample_at_or_after

#: the latest start or end a fault may name, s: the stamps' end (builtin_interfaces/Time's int32)
MAX_FAULT_TIME = 2.0**31


@dataclass(frozen=True)
class FaultedColumns:
    """Where a fault acts in an output's row."""

    measured: slice  # the measurement bias, noise, spikes and a stuck value act on
    held: slice  # what a stuck output repeats: the measurement and its covariance
    quantity: str  # vector (added), rotation (a unit vector turned), quaternion (q ⊗ exp(v/2))
    unit: str


#: output name -> the columns faults act on: the imu's angular velocity (13:16; with its
#: covariance 16:25 when stuck), the magnetometer's field (0:3; covariance 3:12), the sun sensor's
#: unit vector (0:3), the star tracker's orientation (0:4; covariance 4:13)
FAULTED_OUTPUTS = {
    'imu': FaultedColumns(slice(13, 16), slice(13, 25), 'vector', 'rad/s'),
    'magnetometer': FaultedColumns(slice(0, 3), slice(0, 12), 'vector', 'T'),
    'sun_sensor': FaultedColumns(slice(0, 3), slice(0, 3), 'rotation', 'rad'),
    'star_tracker': FaultedColumns(slice(0, 4), slice(0, 13), 'quaternion', 'rad'),
}


@dataclass(frozen=True)
class Fault:
    kind: str
    output: str  # the output's topic
    start: float  # s of the run
    end: float | None  # s; None: until the run ends
    index: int  # its place in its list: what its draws are keyed by
    value: tuple | None = None  # stuck at a given value (None: at the last one)
    step: tuple | None = None  # bias
    sigma: float | None = None  # noise
    magnitude: float | None = None  # spikes
    probability: float | None = None  # spikes on each sample with it
    period: float | None = None  # spikes every period from start
    wheel: str | None = None  # wheel_stuck, wheel_torque_error: the wheel's name
    topic: str | None = None  # the torque faults: their torque_command's topic (None: the only)
    seed: int | None = None  # the actuators' noise faults: their draws' seed
    noise: tuple | None = None  # the actuators' noise faults: 1-sigma, one a component
    bias: tuple | None = None  # torque_error, wheel_torque_error: added, N m (one a component)
    scale: tuple | None = None  # torque_error, wheel_torque_error: the factor (one a component)
    #: where it was written (``faults[1].wheel_stuck``): errors found later name it
    path: str = field(default='', compare=False)

    @property
    def target(self) -> str:
        """Return what it acts on: the output's topic, the wheel's name or the effect's."""
        return self.wheel or self.output or self.topic or ACTUATOR_FAULTS.get(self.kind, '')


_TIME = number(minimum=0.0, maximum=MAX_FAULT_TIME, unit='s')
_COMMON = {
    'output': Param(text(), description="the output's topic: imu, star_tracker, ..."),
    'start': Param(_TIME, description='s of the run'),
    'end': Param(_TIME, None),
}
FAULT_KINDS = {
    'stuck': {'value': Param(vector(3, 4), None, 'default: the last value read')},
    'bias': {'step': Param(vector(3), description="the step, in the output's unit")},
    'noise': {'sigma': Param(number(minimum=0.0), description='1-sigma per axis')},
    'spikes': {
        'magnitude': Param(number(minimum=0.0), description="a spike's size"),
        'probability': Param(number(positive=True, maximum=1.0), None),
        'period': Param(number(positive=True, maximum=MAX_FAULT_TIME, unit='s'), None),
    },
    'dropout': {},
}
#: actuator fault kind -> the effect it acts on (its fields replace ``output``)
ACTUATOR_FAULTS = {
    'wheel_stuck': 'reaction_wheels',
    'wheel_torque_error': 'reaction_wheels',
    'magnetorquer_stuck': 'magnetorquers',
    'torque_stuck': 'torque_command',
    'torque_error': 'torque_command',
    'torque_noise': 'torque_command',
    'wheel_torque_noise': 'reaction_wheels',
    'dipole_noise': 'magnetorquers',
}
#: the actuator faults that scale and offset an input (the others replace it)
ERROR_FAULTS = ('torque_error', 'wheel_torque_error')
#: the actuator faults that add a seeded white noise to an input
NOISE_FAULTS = ('torque_noise', 'wheel_torque_noise', 'dipole_noise')
#: the faults of a torque_command, which a ``topic`` may choose
TORQUE_FAULTS = ('torque_stuck', 'torque_error', 'torque_noise')


def _per_axis(value, path):
    """Check a number, or three (one per axis); return three."""
    if isinstance(value, (list, tuple)):
        return vector(3)(value, path)
    return (number()(value, path),) * 3


def _sigmas(unit: str):
    """Build a checker of a 1-sigma >= 0: a number, or three (one per axis); return three."""
    def check(value, path):
        if isinstance(value, (list, tuple)):
            values = vector(3, unit=unit)(value, path)
            if (values < 0.0).any():
                raise FieldError(path, f'every entry must be >= 0 {unit}, got {shown(value)}')
            return tuple(float(x) for x in values)
        return (number(minimum=0.0, unit=unit)(value, path),) * 3

    return check


_WHEEL = Param(text(), description="the wheel's name")
_TOPIC = Param(text(), None, "the torque_command's topic (default: the scene's only one)")
_SEED = Param(integer(0, 2**63 - 1), 0, "the noise's seed (with the fault's place in its list)")
_ACTUATOR_KINDS = {
    'wheel_stuck': {'wheel': _WHEEL},
    'wheel_torque_error': {
        'wheel': _WHEEL,
        'bias': Param(number(unit='N m'), None, 'added to the motor torque asked, N m'),
        'scale': Param(number(), None, 'the factor of the motor torque asked'),
    },
    'magnetorquer_stuck': {
        'value': Param(vector(3, unit='A m^2'), None, 'default: the last dipole asked for')
    },
    'torque_stuck': {
        'value': Param(vector(3, unit='N m'), None, 'default: the last torque held'),
        'topic': _TOPIC,
    },
    'torque_error': {
        'bias': Param(vector(3, unit='N m'), None, "added to the torque, in the effect's frame"),
        'scale': Param(_per_axis, None, "the torque's factor: a number, or one per axis"),
        'topic': _TOPIC,
    },
    'torque_noise': {
        'sigma': Param(_sigmas('N m'), description='1-sigma, N m: a number, or one per axis'),
        'seed': _SEED,
        'topic': _TOPIC,
    },
    'wheel_torque_noise': {
        'wheel': _WHEEL,
        'sigma': Param(number(minimum=0.0, unit='N m'), description='1-sigma, N m'),
        'seed': _SEED,
    },
    'dipole_noise': {
        'sigma': Param(_sigmas('A m^2'), description='1-sigma, A m^2: a number, or one per axis'),
        'seed': _SEED,
    },
}
_WINDOW = {key: _COMMON[key] for key in ('start', 'end')}


def parse_faults(data, path: str, outputs, first_index: int = 0) -> tuple[Fault, ...]:
    """
    Check a list of faults against the run's ``outputs``; return them.

    Every error is a ``FieldError`` naming its path (``faults[1].bias.step``). ``first_index``:
    the index of the first fault (its draws' key).
    """
    entries = listing(lambda entry, where: entry)(data, path)
    by_topic = {output.topic: output for output in outputs}
    faults = []
    for place, entry in enumerate(entries):
        where = child(path, place)
        kind, parameters = one_key(entry, where, {**FAULT_KINDS, **_ACTUATOR_KINDS}, 'fault kind')
        where = child(where, kind)
        if kind in ACTUATOR_FAULTS:
            values = fields(parameters, where, {**_WINDOW, **_ACTUATOR_KINDS[kind]})
            _check_window(values, where)
            faults.append(_actuator_fault(kind, values, where, first_index + place))
            continue
        values = fields(parameters, where, {**_COMMON, **FAULT_KINDS[kind]})
        output = by_topic.get(values['output'])
        if output is None or output.name not in FAULTED_OUTPUTS:
            sensors = [topic for topic, o in by_topic.items() if o.name in FAULTED_OUTPUTS]
            raise FieldError(
                child(where, 'output'),
                f'{shown(values["output"])} is not the topic of a sensor output of the scene '
                f'(sensors: {", ".join(sensors) or "none"}; faults act on '
                f'{", ".join(FAULTED_OUTPUTS)})',
            )
        _check_window(values, where)
        faults.append(_fault(kind, values, output.name, where, first_index + place))
    return tuple(faults)


def _check_window(values: dict, where: str) -> None:
    end = values['end']
    if end is not None and end <= values['start']:
        raise FieldError(
            child(where, 'end'), f'must be after start ({values["start"]:g} s), got {end:g} s'
        )


def _actuator_fault(kind: str, values: dict, where: str, index: int) -> Fault:
    """Return an actuator's fault; what it names is checked against a run's effects later."""
    value = values.get('value')
    errors = {}
    if kind in ERROR_FAULTS:
        bias, scale = values['bias'], values['scale']
        if bias is None and scale is None:
            raise FieldError(where, "give 'bias' (N m), 'scale' or both")
        width = 3 if kind == 'torque_error' else 1
        errors = {
            'bias': (0.0,) * width if bias is None else _floats(bias, width),
            'scale': (1.0,) * width if scale is None else _floats(scale, width),
        }
    noise = {}
    if kind in NOISE_FAULTS:
        sigma = values['sigma']
        noise = {
            'seed': values['seed'],
            'noise': tuple(sigma) if isinstance(sigma, tuple) else (float(sigma),),
        }
    return Fault(
        kind=kind,
        output='',
        start=values['start'],
        end=values['end'],
        index=index,
        value=None if value is None else tuple(float(x) for x in value),
        wheel=values.get('wheel'),
        topic=values.get('topic'),
        path=where,
        **errors,
        **noise,
    )


def _floats(values, width: int) -> tuple:
    """Return a number or numbers as ``width`` Python floats."""
    return tuple(float(x) for x in (values if width > 1 else (values,)))


def _fault(kind: str, values: dict, name: str, where: str, index: int) -> Fault:
    common = {
        'kind': kind,
        'output': values['output'],
        'start': values['start'],
        'end': values['end'],
        'index': index,
    }
    if kind == 'stuck':
        value = values['value']
        if value is None:
            return Fault(**common)
        width = 4 if name == 'star_tracker' else 3
        if value.size != width:
            raise FieldError(
                child(where, 'value'),
                f'{name} carries {width} numbers ('
                + ('a unit quaternion x, y, z, w' if width == 4 else FAULTED_OUTPUTS[name].unit)
                + f'), got {value.size}',
            )
        if width == 4:
            try:
                value = unit_quaternion(value, 'value')
            except ValueError as error:
                raise FieldError(child(where, 'value'), str(error).split(': ', 1)[-1]) from None
        return Fault(**common, value=tuple(float(x) for x in value))
    if kind == 'bias':
        return Fault(**common, step=tuple(float(x) for x in values['step']))
    if kind == 'noise':
        return Fault(**common, sigma=values['sigma'])
    if kind == 'spikes':
        if (values['probability'] is None) == (values['period'] is None):
            raise FieldError(
                where, "give either 'probability' (per sample) or 'period' (s), not "
                + ('both' if values['probability'] is not None else 'neither')
            )
        return Fault(
            **common,
            magnitude=values['magnitude'],
            probability=values['probability'],
            period=values['period'],
        )
    return Fault(**common)


def describe_fault(fault: Fault) -> str:
    """Say what a fault does, in one line: ``bias imu [2, 4) s step [0.1, 0, 0]``."""
    end = '...' if fault.end is None else f'{fault.end:g}'
    detail = {
        'stuck': 'at the last value'
        if fault.value is None
        else 'at ' + _values(fault.value),
        'bias': f'step {_values(fault.step)}' if fault.step else '',
        'noise': f'sigma {fault.sigma:g}' if fault.sigma is not None else '',
        'spikes': f'magnitude {fault.magnitude:g} '
        + (
            f'probability {fault.probability:g}'
            if fault.probability is not None
            else f'period {fault.period:g} s'
        )
        if fault.magnitude is not None
        else '',
        'dropout': 'no message',
        'wheel_stuck': 'no motor torque',
        'magnetorquer_stuck': 'at the last dipole'
        if fault.value is None
        else 'at ' + _values(fault.value) + ' A m^2',
        'torque_stuck': 'at the last torque'
        if fault.value is None
        else 'at ' + _values(fault.value) + ' N m',
        'torque_error': _error(fault),
        'wheel_torque_error': _error(fault),
        'torque_noise': _noise(fault, 'N m'),
        'wheel_torque_noise': _noise(fault, 'N m'),
        'dipole_noise': _noise(fault, 'A m^2'),
    }[fault.kind]
    return f'{fault.kind} {fault.target} [{fault.start:g}, {end}) s {detail}'.rstrip()


def _values(values) -> str:
    return '[' + ', '.join(f'{x:g}' for x in values) + ']'


def _error(fault: Fault) -> str:
    """Say an error fault's factor and bias: ``scale 0.5 bias 0.001 N m``."""
    if fault.scale is None:
        return ''
    if len(fault.scale) == 1:
        return f'scale {fault.scale[0]:g} bias {fault.bias[0]:g} N m'
    return f'scale {_values(fault.scale)} bias {_values(fault.bias)} N m'


def _noise(fault: Fault, unit: str) -> str:
    """Say an actuator noise's 1-sigma and seed: ``sigma 0.0001 N m seed 7``."""
    if fault.noise is None:
        return ''
    sigma = f'{fault.noise[0]:g}' if len(set(fault.noise)) == 1 else _values(fault.noise)
    return f'sigma {sigma} {unit} seed {fault.seed}'


def spike_period_samples(fault: Fault, rate: float, first: int, stop: int) -> list:
    """
    Return the samples ``j`` in ``[first, stop)`` of a periodic spike fault at ``rate`` Hz.

    The first sample at or after ``start + n period`` for each ``n >= 0`` (the grid's rule).
    """
    n = max(0, math.floor((first / rate - fault.start) / fault.period) - 1)
    found = []
    while True:
        j = first_sample_at_or_after(fault.start + n * fault.period, rate)
        if j >= stop:
            return found
        if j >= first and (not found or found[-1] != j):
            found.append(j)
        n += 1


__all__ = [
    'ACTUATOR_FAULTS',
    'ERROR_FAULTS',
    'NOISE_FAULTS',
    'TORQUE_FAULTS',
    'FAULTED_OUTPUTS',
    'FAULT_KINDS',
    'Fault',
    'FaultedColumns',
    'MAX_FAULT_TIME',
    'describe_fault',
    'parse_faults',
    'spike_period_samples',
]
