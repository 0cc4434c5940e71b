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
Dispersions: how each run's inputs are drawn from the nominal scene.

In Basilisk's vocabulary, a dispersion is a small object that draws one input from the run's own
generator.

A campaign file maps a **target** (a path into the scene) to a **dispersion**::

    dispersions:
      body.moments: {relative: {normal: {sigma: 0.02}}}     # each principal moment, independently
      initial.angular_velocity:                             # one per axis (null: that axis fixed)
        - {absolute: {uniform: {low: -0.01, high: 0.01}}}
        - {replace: {values: [4.0, 5.0, 6.0]}}              # a sweep: run i takes values[i % 3]
        - null
      initial.orientation: {small_rotation: {sigma: 0.01}}  # or {uniform: {}}: uniform on SO(3)
      effects[0].damper.damping: {relative: {truncated_normal: {sigma: 0.2, low: -0.5, high: 0.5}}}
      effects[1].external_torque.torque:                    # a vector as a whole
        direction: {cone: {half_angle: 0.05}}               # rad: uniform within the cone
        magnitude: {relative: {normal: {sigma: 0.1}}}       # |torque|, a number
      effects[2].external_torque.schedule[2].torque: {absolute: {normal: {sigma: 0.001}}}

Targets: ``body.moments`` (principal moments; a scene given as a tensor keeps its principal axes),
``body.inertia`` (the scene's own 3 or 6 inertia numbers, each dispersed),
``initial.angular_velocity`` (rad/s, body frame), ``initial.orientation``, and any number or list
of numbers of an effect: ``effects[i].NAME.PARAMETER`` (the scene's ``i``-th effect, which must be
``NAME``), followed by list items by index and mapping keys down to a number or a vector
(``effects[0].external_torque.schedule[2].torque``, ``effects[0].external_torque.torque[1]``,
``effects[0].rotor.axis``). An output's parameters are an effect's
(``effects[2].imu.gyro_noise_density``, ``effects[1].magnetometer.bias``; its ``seed`` is not
dispersed: every run keeps the scene's), and so are a fault's numbers in ``faults:``
(``faults[i].KIND.FIELD``: ``faults[0].bias.start``, ``faults[1].noise.sigma``,
``faults[0].bias.step``; an actuator's fault, its window and the fields the scene gives it,
``faults[0].magnetorquer_stuck.value``). ``orbit.ELEMENT`` disperses a Keplerian element of the
scene's orbit (:data:`ORBIT_ELEMENTS`, in the scene's SI units: m and rad); the epoch, the start
and ``j2`` are not dispersed, nor a TLE orbit (SGP4 propagates its mean elements whole). Every
such number is checked again in each run's scene as a scene file's is (a negative noise, an
eccentricity outside ``[0, 1)``, a perigee inside the Earth): a run whose draw the scene refuses is
a row ``invalid_scene`` whose reason names the field (``orbit.eccentricity: the perigee radius ...
is inside the Earth``).

A **vector** takes one dispersion (every component, independently), a list with one per component
(``null``: that component kept), or, for a vector in space (``initial.angular_velocity``, a
3-vector of an effect), a dispersion of the vector **as a whole**: ``direction`` (the vector
turned, its magnitude kept) and ``magnitude`` (``|v|`` dispersed as a number, its direction kept),
either or both. Directions: ``cone {half_angle}`` (rad, in [0, pi]: uniform on the cap of
directions within ``half_angle`` of the nominal one) or ``small_rotation {sigma}`` (the attitude's:
the vector turned by ``exp(w)``, ``w ~ N(0, sigma^2 I)`` rad). ``misalignment {sigma}`` (arcsec, a
datasheet's unit; instead of ``direction``) tilts an axis, such as a reaction wheel's
(``effects[0].reaction_wheels.wheels[1].axis: {misalignment: {sigma: 60}}``): by the rotation
vector ``e = e1 n1 + e2 n2``, ``e1, e2 ~ N(0, sigma^2)``, ``n1, n2`` normal to the nominal axis
and to each other, so the misalignment angle is ``|e|``, exactly Rayleigh: mean
``sigma sqrt(pi / 2)``, median ``sigma sqrt(2 ln 2)``, its azimuth uniform (``small_rotation``'s
rotation about the axis itself would be wasted). A wheel's field its ``preset`` fills is dispersed
from the preset's value. A whole-vector dispersion of a zero
vector is refused (it has no direction); a run whose drawn magnitude is negative fails
(``invalid_scene``, with the drawn value).

Modes: ``relative`` (``x0 (1 + d)``), ``absolute`` (``x0 + d``), ``replace`` (``d``). Distributions
of ``d``: ``normal {sigma, mean: 0}``, ``uniform {low, high}``,
``truncated_normal {sigma, low, high, mean: 0}`` (by the inverse normal CDF: one uniform number a
draw), ``values [...]`` (not random: run ``i`` takes ``values[i % len(values)]``). Orientation:
``uniform`` (uniform on SO(3): a normalised 4-D normal vector) or ``small_rotation {sigma}``:
``q = exp(v / 2) ⊗ q0`` with ``v ~ N(0, sigma^2 I)`` (rad), a rotation of the nominal attitude
about inertial-frame axes, so that in a torque-free scene the attitude stays exactly that rotation
away from the nominal run's.

**Seeds.** Run ``i`` draws from ``Generator(PCG64(SeedSequence(seed, spawn_key=(i,))))``, which is
``SeedSequence(seed).spawn(runs)[i]``: a run's inputs depend only on ``(seed, i)``, never on chunks
or workers. Within a run the targets draw in a fixed order: the non-body targets sorted by path,
then the body (so that redrawing an impossible body does not move the other draws); a vector's
components in order; a whole vector its direction, then its magnitude.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
import math
import re

import numpy as np
from scipy import special

from ..core.checks.schema import (
    check_keys,
    child,
    FieldError,
    fields,
    number,
    one_key,
    Param,
    shown,
    text,
)
from ..core.effects.wheel_presets import PRESETS, with_preset
from ..core.frames import quaternion

MODES = ('relative', 'absolute', 'replace')


# -- distributions of one number ------------------------------------------------------------------
class Distribution(abc.ABC):
    name = ''
    parameters: dict = {}

    @abc.abstractmethod
    def draw(self, rng: np.random.Generator, run: int) -> float: ...

    def describe(self) -> str:
        return self.name


@dataclass(frozen=True)
class Normal(Distribution):
    sigma: float
    mean: float = 0.0
    name = 'normal'

    def draw(self, rng, run):
        return self.mean + self.sigma * float(rng.standard_normal())


@dataclass(frozen=True)
class Uniform(Distribution):
    low: float
    high: float
    name = 'uniform'

    def draw(self, rng, run):
        return self.low + (self.high - self.low) * float(rng.random())


@dataclass(frozen=True)
class TruncatedNormal(Distribution):
    sigma: float
    low: float
    high: float
    mean: float = 0.0
    name = 'truncated_normal'

    def draw(self, rng, run):
        a = special.ndtr((self.low - self.mean) / self.sigma)
        b = special.ndtr((self.high - self.mean) / self.sigma)
        value = self.mean + self.sigma * float(special.ndtri(a + (b - a) * float(rng.random())))
        # the inverse CDF's rounding never leaves [low, high]
        return min(max(value, self.low), self.high)


@dataclass(frozen=True)
class Values(Distribution):
    values: tuple
    name = 'values'

    def draw(self, rng, run):
        return self.values[run % len(self.values)]


# a truncated normal's interval must hold this much of the normal's probability
MIN_TRUNCATED_MASS = 1e-12


def _normal(values, path):
    return Normal(values['sigma'], values['mean'])


def _uniform(values, path):
    if values['low'] > values['high']:
        raise FieldError(
            path, f'low ({values["low"]:g}) must not exceed high ({values["high"]:g})'
        )
    return Uniform(values['low'], values['high'])


def _truncated(values, path):
    low, high, mean, sigma = values['low'], values['high'], values['mean'], values['sigma']
    if not low < high:
        raise FieldError(path, f'low ({low:g}) must be below high ({high:g})')
    mass = float(special.ndtr((high - mean) / sigma) - special.ndtr((low - mean) / sigma))
    if not mass > MIN_TRUNCATED_MASS:
        raise FieldError(
            path,
            f'[{low:g}, {high:g}] holds no probability of a normal of mean {mean:g} and sigma '
            f'{sigma:g} (mass {mass:.3g})',
        )
    return TruncatedNormal(sigma, low, high, mean)


_SIGMA = Param(
    number(minimum=0.0),
    description="standard deviation, >= 0 (in the target's units, or a fraction when relative)",
)
_DISTRIBUTIONS = {
    'normal': ({'sigma': _SIGMA, 'mean': Param(number(), 0.0)}, _normal),
    'uniform': (
        {
            'low': Param(number(), description='lower bound'),
            'high': Param(number(), description='upper bound'),
        },
        _uniform,
    ),
    'truncated_normal': (
        {
            'sigma': Param(
                number(positive=True), description='standard deviation before truncation, > 0'
            ),
            'mean': Param(number(), 0.0),
            'low': Param(number(), description='lower bound'),
            'high': Param(number(), description='upper bound'),
        },
        _truncated,
    ),
    'values': (None, None),
}
MAX_VALUES = 100_000


def parse_distribution(value, path) -> Distribution:
    name, parameters = one_key(value, path, _DISTRIBUTIONS, 'distribution')
    where = child(path, name)
    if name == 'values':
        if not isinstance(parameters, list) or not parameters or len(parameters) > MAX_VALUES:
            raise FieldError(
                where, f'expected a list of 1 to {MAX_VALUES} numbers, got {shown(parameters)}'
            )
        check = number()
        return Values(tuple(check(x, child(where, i)) for i, x in enumerate(parameters)))
    params, build = _DISTRIBUTIONS[name]
    return build(fields(parameters, where, params), where)


@dataclass(frozen=True)
class Dispersion:
    """``mode`` of the nominal ``x0`` by a drawn ``d``."""

    mode: str
    distribution: Distribution

    def draw(self, nominal: float, rng, run: int) -> float:
        d = self.distribution.draw(rng, run)
        if self.mode == 'relative':
            return nominal * (1.0 + d)
        if self.mode == 'absolute':
            return nominal + d
        return d


def parse_dispersion(value, path, *, nominal_known: bool = True) -> Dispersion:
    mode, distribution = one_key(value, path, MODES, 'mode (how a draw changes the nominal)')
    if mode != 'replace' and not nominal_known:
        raise FieldError(child(path, mode), "the scene gives no nominal value here; use 'replace'")
    return Dispersion(mode, parse_distribution(distribution, child(path, mode)))


class RefusedDraw(ValueError):
    """A draw that makes no run (a negative magnitude): the drawn values and the reason."""

    def __init__(self, values: np.ndarray, reason: str):
        super().__init__(reason)
        self.values, self.reason = values, reason


# -- targets --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class NumberTarget:
    """One number: its dispersion of the nominal (``None`` when the scene gives none)."""

    path: str
    nominal: float | None
    dispersion: Dispersion

    @property
    def columns(self) -> tuple:
        return (self.path,)

    def draw(self, rng, run) -> np.ndarray:
        return np.array([self.dispersion.draw(self.nominal, rng, run)])


@dataclass(frozen=True)
class VectorTarget:
    """A vector of numbers, each component with its own dispersion or none."""

    path: str
    nominal: tuple
    dispersions: tuple  # Dispersion | None per component

    @property
    def columns(self) -> tuple:
        return tuple(f'{self.path}[{k}]' for k in range(len(self.nominal)))

    def draw(self, rng, run) -> np.ndarray:
        return np.array(
            [
                x0 if d is None else d.draw(x0, rng, run)
                for x0, d in zip(self.nominal, self.dispersions)
            ]
        )


@dataclass(frozen=True)
class Direction:
    """How a whole vector's direction is turned: ``cone`` (half-angle) or ``small_rotation``."""

    kind: str  # cone | small_rotation | misalignment
    angle: float  # rad: the cone's half-angle, or the rotation vector's sigma

    def turn(self, unit: np.ndarray, rng) -> np.ndarray:
        """Return the unit vector ``unit`` turned by a drawn rotation."""
        if self.kind == 'misalignment':
            # a tilt by |e| towards e, e normal to the axis: the angle from unit is |e| exactly
            first, second = _normal_pair(unit)
            e1, e2 = (self.angle * rng.standard_normal(2)).tolist()
            tilt = math.hypot(e1, e2)
            if tilt == 0.0:
                return unit
            towards = (e1 * first + e2 * second) / tilt
            turned = math.cos(tilt) * unit + math.sin(tilt) * towards
            return turned / math.sqrt(float(turned @ turned))
        if self.kind == 'small_rotation':
            rotation = quaternion.exp_rotation(self.angle * rng.standard_normal(3))
            turned = quaternion.rotate(rotation, unit)
            return turned / math.sqrt(float(turned @ turned))
        # uniform on the cap: the cosine of the angle from the axis is uniform on [cos A, 1]
        cosine = 1.0 - float(rng.random()) * (1.0 - math.cos(self.angle))
        azimuth = 2.0 * math.pi * float(rng.random())
        sine = math.sqrt(max(0.0, 1.0 - cosine * cosine))
        first, second = _normal_pair(unit)
        turned = cosine * unit + sine * (math.cos(azimuth) * first + math.sin(azimuth) * second)
        return turned / math.sqrt(float(turned @ turned))


def _normal_pair(unit: np.ndarray) -> tuple:
    """Two unit vectors normal to ``unit`` and to each other, a function of ``unit`` only."""
    axis = np.zeros(3)
    axis[int(np.argmin(np.abs(unit)))] = 1.0
    first = quaternion.cross(unit, axis)
    first = first / math.sqrt(float(first @ first))
    return first, quaternion.cross(unit, first)


@dataclass(frozen=True)
class WholeVectorTarget:
    """A 3-vector dispersed as a whole: its direction turned, its magnitude dispersed."""

    path: str
    nominal: tuple
    direction: Direction | None
    magnitude: Dispersion | None

    @property
    def columns(self) -> tuple:
        return tuple(f'{self.path}[{k}]' for k in range(len(self.nominal)))

    def draw(self, rng, run) -> np.ndarray:
        nominal = np.asarray(self.nominal, dtype=float)
        size = math.sqrt(float(nominal @ nominal))
        unit = nominal / size
        if self.direction is not None:
            unit = self.direction.turn(unit, rng)
        if self.magnitude is not None:
            size = self.magnitude.draw(size, rng, run)
        if size < 0.0:
            raise RefusedDraw(
                size * unit, f'{self.path}: the drawn magnitude must be >= 0, got {size:.6g}'
            )
        return size * unit


@dataclass(frozen=True)
class OrientationTarget:
    path: str
    nominal: tuple  # q_NB (x, y, z, w)
    kind: str  # uniform | small_rotation
    sigma: float = 0.0

    @property
    def columns(self) -> tuple:
        return tuple(f'{self.path}[{k}]' for k in range(4))

    def draw(self, rng, run) -> np.ndarray:
        if self.kind == 'uniform':
            while True:  # a 4-D normal vector, normalised, is uniform on S^3 (and so q on SO(3))
                v = rng.standard_normal(4)
                norm = math.sqrt(float(v @ v))
                if norm > 1e-6:
                    q = v / norm
                    return q if q[3] >= 0.0 else -q
        rotation = quaternion.exp_rotation(self.sigma * rng.standard_normal(3))
        q = quaternion.multiply(rotation, np.asarray(self.nominal))
        return q / math.sqrt(float(q @ q))


class DrawnThrough:
    """A target drawn by its ``inner`` target, its values placed where the target says."""

    @property
    def columns(self) -> tuple:
        return self.inner.columns

    def draw(self, rng, run) -> np.ndarray:
        return self.inner.draw(rng, run)


@dataclass(frozen=True)
class EffectTarget(DrawnThrough):
    """
    A number or a vector of an effect or a fault: where it sits in the scene, how it is drawn.

    ``section``: the scene's list it is in, ``effects`` or ``faults`` (both lists of one-key
    mappings ``- NAME: {parameters}``).
    """

    path: str  # SECTION[i].NAME.PARAMETER, then [k] and .KEY down to the dispersed value
    index: int
    effect: str  # the effect's name, or the fault's kind
    keys: tuple  # the parameter, then the list indices and mapping keys down to the value
    inner: NumberTarget | VectorTarget | WholeVectorTarget
    section: str = 'effects'

    @property
    def parameter(self) -> str:
        return self.keys[0]

    def overlaps(self, other: EffectTarget) -> bool:
        """Tell whether the two targets reach the same number (one holds the other)."""
        shorter = min(len(self.keys), len(other.keys))
        return (
            self.section == other.section
            and self.index == other.index
            and self.keys[:shorter] == other.keys[:shorter]
        )

    def place(self, document: dict, values: np.ndarray) -> None:
        """
        Write drawn ``values`` into ``document``, a run's own copy of the scene file's mapping.

        A number is written as a number, a vector as a list.
        """
        entry = document[self.section][self.index]
        parameters = entry[self.effect] = dict(entry[self.effect] or {})
        holder = parameters
        for key in self.keys[:-1]:
            holder = holder[key]
        holder[self.keys[-1]] = (
            float(values[0])
            if isinstance(self.inner, NumberTarget)
            else [float(x) for x in values]
        )


@dataclass(frozen=True)
class OrbitTarget(DrawnThrough):
    """A Keplerian element of the scene's ``orbit:`` (SI: m, rad, as the scene writes it)."""

    path: str  # orbit.ELEMENT
    element: str
    inner: NumberTarget

    def place(self, document: dict, values: np.ndarray) -> None:
        """Write the drawn element into ``document``, a run's own copy of the scene's mapping."""
        orbit = document['orbit'] = dict(document['orbit'])
        orbit[self.element] = float(values[0])


_NAME = r'[A-Za-z_][A-Za-z0-9_]*'
_EFFECT_PATH = re.compile(
    rf'^(effects|faults)\[(\d+)\]\.({_NAME})\.({_NAME})((?:\[\d+\]|\.{_NAME})*)$'
)
_STEP = re.compile(rf'\[(\d+)\]|\.({_NAME})')
TARGETS = (
    'body.moments',
    'body.inertia',
    'initial.angular_velocity',
    'initial.orientation',
    'effects[i].NAME.PARAMETER (then [k] and .KEY down to a number or a list of numbers)',
    'orbit.ELEMENT (a Keplerian element: semi_major_axis, eccentricity, inclination, raan, '
    'argument_of_perigee, mean_anomaly)',
    'faults[i].KIND.FIELD (then [k])',
)
#: the orbit's elements a campaign disperses (numbers; the epoch, start, j2 and a TLE are not)
ORBIT_ELEMENTS = (
    'semi_major_axis',
    'eccentricity',
    'inclination',
    'raan',
    'argument_of_perigee',
    'mean_anomaly',
)
WHOLE = ('direction', 'misalignment', 'magnitude')
ARCSEC = math.pi / (180.0 * 3600.0)  # rad
_DIRECTIONS = {
    'cone': Param(
        number(minimum=0.0, maximum=math.pi, unit='rad'),
        description="the cone's half-angle about the nominal direction, rad, in [0, pi]",
    ),
    'small_rotation': Param(
        number(minimum=0.0, unit='rad'),
        description='standard deviation of each rotation-vector component, rad',
    ),
}
_DIRECTION_PARAMETER = {'cone': 'half_angle', 'small_rotation': 'sigma'}


def parse_target(
    key, value, path: str, scene, document
) -> VectorTarget | WholeVectorTarget | OrientationTarget | EffectTarget:
    """Parse the dispersion of ``key`` in ``scene`` (its raw ``document`` names the effects)."""
    from ..core.body.rigid_body import RigidBody

    if key in ('body.moments', 'body.inertia'):
        nominal = (
            RigidBody.from_inertia(scene.inertia).moments
            if key == 'body.moments'
            else scene.inertia
        )
        return _vector_target(key, tuple(float(x) for x in nominal), value, path, in_space=False)
    if key == 'initial.angular_velocity':
        return _vector_target(
            key, tuple(float(x) for x in scene.angular_velocity), value, path, in_space=True
        )
    if key == 'initial.orientation':
        kind, parameters = one_key(
            value, path, ('uniform', 'small_rotation'), 'attitude dispersion'
        )
        where = child(path, kind)
        if kind == 'uniform':
            fields(parameters, where, {})
            return OrientationTarget(key, tuple(scene.orientation), 'uniform')
        values = fields(
            parameters,
            where,
            {
                'sigma': Param(
                    number(minimum=0.0, unit='rad'),
                    description='standard deviation of each rotation-vector component, rad',
                )
            },
        )
        return OrientationTarget(key, tuple(scene.orientation), 'small_rotation', values['sigma'])
    if str(key).startswith('orbit.'):
        return _orbit_target(str(key), value, path, document)
    return _effect_target(key, value, path, document)


def _orbit_target(key: str, value, path: str, document) -> OrbitTarget:
    """
    Parse the dispersion of a Keplerian element of the scene's ``orbit:``.

    The element is checked again in each run's scene (``KeplerOrbit``: ``0 <= e < 1``, the
    inclination in ``[0, pi]``, the perigee above the Earth's surface): a run whose drawn elements
    make no orbit is a row ``invalid_scene`` naming the element.
    """
    from ..core.environment.orbit import ELEMENTS

    element = key[len('orbit.'):]
    orbit = document.get('orbit')
    if not isinstance(orbit, dict):
        raise FieldError(path, 'outside the scene: it has no orbit')
    if 'tle' in orbit:
        raise FieldError(
            path,
            "the scene's orbit is a two-line element set (orbit.tle), which SGP4 propagates "
            'whole: its elements are not dispersed; write the orbit as Keplerian elements at an '
            'epoch to disperse them',
        )
    if element in ('epoch', 'start'):
        raise FieldError(
            path,
            f'orbit.{element} is an instant (UTC), not dispersed; disperse orbit.mean_anomaly for '
            'where the body is on its orbit',
        )
    if element == 'j2':
        raise FieldError(path, 'orbit.j2 is a switch (true or false), not a number to disperse')
    if element not in ORBIT_ELEMENTS:
        raise FieldError(
            path,
            f'outside the scene: the orbit has no element {shown(element)}'
            f'{_hint(element, ORBIT_ELEMENTS)} (elements dispersed: {", ".join(ORBIT_ELEMENTS)})',
        )
    # a number: the scene's load has checked the element
    nominal = float(orbit.get(element, ELEMENTS[element].default))
    return OrbitTarget(key, element, NumberTarget(key, nominal, parse_dispersion(value, path)))


def _fault_parameters(kind: str, given) -> dict:
    """
    Return the fields of a fault of ``kind`` the scene writes as ``given``.

    A sensor's fault: its window, its output and its kind's own fields (``core.faults.schedule``);
    an actuator's: its window and the fields the scene gives it (a field it leaves out is not
    dispersed). The scene's load checks every drawn value.
    """
    from ..core.faults.schedule import FAULT_KINDS

    window = {
        'start': Param(number(), description='s of the run'),
        'end': Param(number(), None),
    }
    if kind in FAULT_KINDS:
        return {**window, 'output': Param(text()), **FAULT_KINDS[kind]}
    return {**window, **{key: Param(text()) for key in (given or {}) if key not in window}}


def _effect_target(key, value, path: str, document) -> EffectTarget:
    from ..core.effects import EFFECTS
    from ..core.effects.base import OutputEffect

    match = _EFFECT_PATH.match(str(key))
    if not match:
        raise FieldError(path, f'not a target; expected one of {", ".join(TARGETS)}')
    section, index, name, parameter = (
        match.group(1),
        int(match.group(2)),
        match.group(3),
        match.group(4),
    )
    steps = tuple(int(item) if item else name_ for item, name_ in _STEP.findall(match.group(5)))
    entries = document.get(section) or []
    noun = 'effect' if section == 'effects' else 'fault'
    if index >= len(entries):
        raise FieldError(
            path,
            f'outside the scene: it has {len(entries)} {noun}{"s" if len(entries) != 1 else ""}'
            + (f' ({section}[0] to {section}[{len(entries) - 1}])' if entries else ''),
        )
    ((actual, given),) = entries[index].items()
    if actual != name:
        raise FieldError(
            path, f'outside the scene: {section}[{index}] is {actual}, not {shown(name)}'
        )
    declared = (
        EFFECTS[actual].parameters if section == 'effects' else _fault_parameters(actual, given)
    )
    if parameter not in declared:
        raise FieldError(
            path,
            f'outside the scene: {actual} has no {"parameter" if noun == "effect" else "field"} '
            f'{shown(parameter)}{_hint(parameter, declared)} '
            f'({"parameters" if noun == "effect" else "fields"}: {", ".join(declared)})',
        )
    if parameter == 'seed':
        raise FieldError(
            path,
            'a seed is not a physical parameter (a sensor draws its errors from its own seed and '
            "the sample index: every run of the campaign keeps the scene's)"
            if section == 'effects' and issubclass(EFFECTS[actual], OutputEffect)
            else 'a seed is not a physical parameter',
        )
    where = f'{actual}.{parameter}'
    if parameter in (given or {}):
        nominal = given[parameter]
    elif steps:
        raise FieldError(
            path,
            f'the scene does not give {where} (its default is used): write it in the scene file '
            'to disperse a part of it, or disperse it whole',
        )
    else:
        nominal = declared[parameter].default
    for step in steps:
        nominal, where = _step(nominal, step, where, path)
    if nominal is None:  # a parameter the scene leaves out, without a default
        if _takes_vector(declared[parameter].check):
            raise FieldError(path, f'the scene gives no {where}: write one in it to disperse it')
        inner = NumberTarget(key, None, parse_dispersion(value, path, nominal_known=False))
    elif _is_number(nominal):
        inner = NumberTarget(key, float(nominal), parse_dispersion(value, path))
    elif _is_vector(nominal):
        inner = _vector_target(
            key, tuple(float(x) for x in nominal), value, path, in_space=len(nominal) == 3
        )
    elif isinstance(nominal, list) and nominal and all(isinstance(x, dict) for x in nominal):
        raise FieldError(
            path,
            f'only a number or a list of numbers can be dispersed; {where} is a list of '
            f'{len(nominal)} mappings: disperse a number of one by its index, such as '
            f'{where}[0].{next(iter(nominal[0]), "KEY")}',
        )
    else:
        raise FieldError(
            path,
            f'only a number or a list of numbers can be dispersed; {where} is {shown(nominal)}',
        )
    return EffectTarget(key, index, actual, (parameter, *steps), inner, section)


def _step(value, step, where: str, path: str) -> tuple:
    """Go one index or key into ``value`` (at ``where`` in the scene); return it and its place."""
    if isinstance(step, int):
        if not isinstance(value, list):
            raise FieldError(
                path, f'outside the scene: {where} is {shown(value)}, not a list to index with [k]'
            )
        if step >= len(value):
            raise FieldError(
                path,
                f'outside the scene: {where} has {len(value)} item'
                f'{"s" if len(value) != 1 else ""} ({where}[0] to {where}[{len(value) - 1}])',
            )
        return value[step], f'{where}[{step}]'
    if not isinstance(value, dict):
        raise FieldError(
            path, f'outside the scene: {where} is {shown(value)}, not a mapping with a key .{step}'
        )
    if step not in value and value.get('preset') in PRESETS:  # a wheel's preset fills it
        value = with_preset(value)
    if step not in value:
        raise FieldError(
            path,
            f'outside the scene: {where} has no key {shown(step)}{_hint(step, value)} '
            f'(keys: {", ".join(str(k) for k in value)})',
        )
    return value[step], f'{where}.{step}'


def _hint(name: str, known) -> str:
    import difflib

    close = difflib.get_close_matches(name, [str(k) for k in known], n=1)
    return f'; did you mean {close[0]!r}?' if close else ''


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _is_vector(value) -> bool:
    return (
        isinstance(value, (list, tuple, np.ndarray))
        and len(value) > 0
        and all(_is_number(x) for x in value)
    )


def _takes_vector(check) -> bool:
    """Tell whether a parameter's checker takes a 3-vector (and so is no single number)."""
    try:
        check([1.0, 1.0, 1.0], '')
    except (FieldError, TypeError, ValueError):
        return False
    return True


def _vector_target(
    key: str, nominal: tuple, value, path: str, *, in_space: bool
) -> VectorTarget | WholeVectorTarget:
    """
    Parse a vector's dispersion: one for every component, one per component, or as a whole.

    As a whole (``direction``, ``magnitude``) only a vector in space (``in_space``: 3 components
    of a physical vector).
    """
    if isinstance(value, dict) and any(k in WHOLE for k in value):
        if not in_space:
            raise FieldError(
                path,
                f'a direction, a misalignment or a magnitude is for a vector in space; {key} '
                f'takes one dispersion (every component) or a list of {len(nominal)} (one per '
                'component)',
            )
        check_keys(value, WHOLE, path)
        return _whole_vector(key, nominal, value, path)
    if in_space and isinstance(value, dict) and len(value) == 1:
        one_key(
            value,
            path,
            MODES + WHOLE,
            'mode or whole-vector key',
        )
    return VectorTarget(key, nominal, _per_component(value, path, len(nominal)))


def _whole_vector(key: str, nominal: tuple, value: dict, path: str) -> WholeVectorTarget:
    if not math.sqrt(sum(x * x for x in nominal)) > 0.0:
        raise FieldError(
            path,
            'the nominal vector is zero: it has no direction or magnitude to disperse; '
            'disperse it per component',
        )
    direction = None
    if 'direction' in value and 'misalignment' in value:
        raise FieldError(
            child(path, 'misalignment'),
            'turns the direction as direction does: give one of them',
        )
    if 'misalignment' in value:
        where = child(path, 'misalignment')
        sigma = fields(
            value['misalignment'],
            where,
            {
                'sigma': Param(
                    number(minimum=0.0, unit='arcsec'),
                    description="each tilt component's standard deviation, arcsec",
                )
            },
        )['sigma']
        direction = Direction('misalignment', sigma * ARCSEC)
    if 'direction' in value:
        where = child(path, 'direction')
        kind, parameters = one_key(value['direction'], where, _DIRECTIONS, 'direction dispersion')
        name = _DIRECTION_PARAMETER[kind]
        angle = fields(parameters, child(where, kind), {name: _DIRECTIONS[kind]})[name]
        direction = Direction(kind, angle)
    magnitude = (
        parse_dispersion(value['magnitude'], child(path, 'magnitude'))
        if 'magnitude' in value
        else None
    )
    return WholeVectorTarget(key, nominal, direction, magnitude)


def _per_component(value, path: str, size: int) -> tuple:
    if isinstance(value, list):
        if len(value) != size:
            raise FieldError(
                path,
                f'expected one dispersion (every component) or a list of {size} (one per '
                f'component, null for none), got a list of {len(value)}',
            )
        return tuple(
            None if v is None else parse_dispersion(v, child(path, k)) for k, v in enumerate(value)
        )
    dispersion = parse_dispersion(value, path)
    return (dispersion,) * size


def run_generator(seed: int, run: int) -> np.random.Generator:
    """Run ``run``'s generator: ``SeedSequence(seed).spawn(runs)[run]``, built directly."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(run,))))
