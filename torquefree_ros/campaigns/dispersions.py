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

Targets: ``body.moments`` (principal moments; a scene given as a tensor keeps its principal axes),
``body.inertia`` (the scene's own 3 or 6 inertia numbers, each dispersed),
``initial.angular_velocity`` (rad/s, body frame, per axis), ``initial.orientation`` and
``effects[i].NAME.PARAMETER`` (a number parameter of the scene's ``i``-th effect, which must be
``NAME``). A vector target takes one dispersion (every component, independently) or a list with one
per component.

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
then the body (so that redrawing an impossible body does not move the other draws).
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
import math
import re

import numpy as np
from scipy import special

from ..core import quaternion
from ..core.schema import child, FieldError, fields, number, one_key, Param, shown

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


# -- targets --------------------------------------------------------------------------------------
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


@dataclass(frozen=True)
class EffectTarget:
    path: str  # effects[i].NAME.PARAMETER
    index: int
    effect: str
    parameter: str
    nominal: float | None
    dispersion: Dispersion

    @property
    def columns(self) -> tuple:
        return (self.path,)

    def draw(self, rng, run) -> np.ndarray:
        return np.array([self.dispersion.draw(self.nominal, rng, run)])


_EFFECT_PATH = re.compile(
    r'^effects\[(\d+)\]\.([A-Za-z_][A-Za-z0-9_]*)\.([A-Za-z_][A-Za-z0-9_]*)$'
)
TARGETS = (
    'body.moments',
    'body.inertia',
    'initial.angular_velocity',
    'initial.orientation',
    'effects[i].NAME.PARAMETER',
)


def parse_target(
    key, value, path: str, scene, document
) -> VectorTarget | OrientationTarget | EffectTarget:
    """Parse the dispersion of ``key`` in ``scene`` (its raw ``document`` names the effects)."""
    from ..core.effects import EFFECTS
    from ..core.rigid_body import RigidBody

    if key in ('body.moments', 'body.inertia'):
        nominal = (
            RigidBody.from_inertia(scene.inertia).moments
            if key == 'body.moments'
            else scene.inertia
        )
        return VectorTarget(
            key, tuple(float(x) for x in nominal), _per_component(value, path, len(nominal))
        )
    if key == 'initial.angular_velocity':
        return VectorTarget(key, tuple(scene.angular_velocity), _per_component(value, path, 3))
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
    match = _EFFECT_PATH.match(str(key))
    if not match:
        raise FieldError(path, f'not a target; expected one of {", ".join(TARGETS)}')
    index, name, parameter = int(match.group(1)), match.group(2), match.group(3)
    effects = document.get('effects') or []
    if index >= len(effects):
        raise FieldError(
            path,
            f'outside the scene: it has {len(effects)} effect{"s" if len(effects) != 1 else ""}'
            + (f' (effects[0] to effects[{len(effects) - 1}])' if effects else ''),
        )
    ((actual, given),) = effects[index].items()
    if actual != name:
        raise FieldError(
            path, f'outside the scene: effects[{index}] is {actual}, not {shown(name)}'
        )
    declared = EFFECTS[actual].parameters
    if parameter not in declared:
        import difflib

        close = difflib.get_close_matches(parameter, tuple(declared), n=1)
        hint = f'; did you mean {close[0]!r}?' if close else ''
        raise FieldError(
            path,
            f'outside the scene: {actual} has no parameter {shown(parameter)}{hint} '
            f'(parameters: {", ".join(declared)})',
        )
    nominal = (given or {}).get(parameter, declared[parameter].default)
    if nominal is not None and not (
        isinstance(nominal, (int, float)) and not isinstance(nominal, bool)
    ):
        raise FieldError(
            path, f'only a number can be dispersed; {actual}.{parameter} is {shown(nominal)}'
        )
    if actual in ('imu', 'star_tracker') and parameter == 'seed':
        raise FieldError(path, 'a seed is not a physical parameter')
    dispersion = parse_dispersion(value, path, nominal_known=nominal is not None)
    return EffectTarget(
        key, index, actual, parameter, None if nominal is None else float(nominal), dispersion
    )


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
