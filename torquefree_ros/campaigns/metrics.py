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
Metrics: what a campaign keeps of each run, one or more numbers a run.

They are Basilisk's retained variables, reduced to a row. One registry, :data:`METRICS`; a metric
is a Python function.

Adding a metric::

    import numpy as np
    from torquefree_ros.campaigns import metric
    from torquefree_ros.core.checks.schema import Param, number

    @metric("peak_rate", unit="rad/s", parameters={"scale": Param(number(positive=True), 1.0)})
    def peak_rate(samples, scale):
        "The largest |w| over the run, times scale."
        return scale * samples.rate_norm().max(axis=1)

and name it in a campaign file (``metrics: [peak_rate, {peak_rate: {scale: 2}}]`` — each name
once). The function gets a :class:`Samples` of ``n`` runs (``omega_B (n, M, 3)``,
``q_NB (n, M, 4)``, ``internal (n, M, s)``, the bodies, each run's ``systems`` (its body with its
motion effects, for scenes with effects), the ``times (M,)`` of samples ``0 .. M-1`` including the
initial state) and the checked parameters, and returns an ``(n,)`` array (one column,
named after the metric) or a dict ``column -> (n,)`` array whose keys are the ``columns`` declared.
``columns`` may instead be a function of the campaign's scene (``columns(scene) -> tuple``, a
``ValueError`` when the scene has nothing to measure): a metric with a column per wheel, named
after the wheel (``wheel_momentum_peak``). Every run of a campaign has its scene's effects (a
dispersion changes numbers, never names), so a run's columns are the scene's.
It must treat each run on its own (a row may not depend on the other runs of its chunk: the table
does not depend on chunking). In a table, a metric is null for a run that failed and NaN where it
is undefined for a run that did not (``settle_time`` of a run that never settles). Metrics run on
Dask workers: define them in an importable module (or in ``__main__``, which Dask ships by value)
and import it before the campaign is loaded.

**Sensors and commands.** A metric registered with ``needs_sensors=True`` reads the scene's
outputs at the campaign's samples: ``samples.sensor(topic)`` (``(n, M, width)``, each output's
row as ``Plant.sensors().read()`` gives it, NaN where it sends nothing) and
``samples.published(topic)`` (``(n, M)``); the campaign then steps the plant sample by sample
and reads its sensors (also open loop). ``needs_commands=True``: it reads the controller's
commands, ``samples.command(name)`` (``dipole``, ``torque``, ``wheels``: ``(n, M, width)``, what
the law asked for at each sample, held until the next controller sample); refused in a campaign
without a controller. ``check(values, scene)``: optional, raises ``ValueError`` when the
parameters do not fit the scene (a topic it does not publish), refused when the campaign is
loaded.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Callable

import numpy as np

from ..core.checks.schema import (
    child,
    choice,
    FieldError,
    fields,
    integer,
    number,
    one_key,
    Param,
    shown,
    text,
    vector,
)
from ..core.effects.actuators import ReactionWheels
from ..core.frames import quaternion
from ..core.propagators.dynamics import Dynamics


@dataclass(frozen=True)
class Metric:
    name: str
    function: Callable
    columns: tuple | Callable  # the columns, or a function of the scene giving them
    parameters: dict = field(default_factory=dict)
    unit: str = ''
    dtype: str = 'float64'  # float64 | int64
    needs_nominal: bool = False  # the engine computes the undispersed run beside the chunk
    summary: str = ''
    needs_sensors: bool = False  # reads the outputs' rows (the plant steps with its sensors read)
    needs_commands: bool = False  # reads a controller's commands
    check: Callable | None = None  # check(values, scene): a ValueError refuses the parameters


#: metric name -> Metric
METRICS: dict[str, Metric] = {}


def metric(
    name: str,
    *,
    columns=None,
    parameters=None,
    unit: str = '',
    dtype: str = 'float64',
    needs_nominal: bool = False,
    needs_sensors: bool = False,
    needs_commands: bool = False,
    check: Callable | None = None,
):
    """
    Register ``function(samples, **parameters)`` as the metric ``name``.

    See the module docstring.
    """
    if dtype not in ('float64', 'int64'):
        raise ValueError(f'metric {name}: dtype must be float64 or int64, got {dtype!r}')

    def register(function):
        summary = (function.__doc__ or '').strip().split('\n\n')[0].replace('\n', ' ')
        METRICS[name] = Metric(
            name,
            function,
            columns if callable(columns) else tuple(columns or (name,)),
            dict(parameters or {}),
            unit,
            dtype,
            needs_nominal,
            summary,
            needs_sensors or needs_commands,
            needs_commands,
            check,
        )
        return function

    return register


@dataclass(frozen=True)
class MetricUse:
    """A metric as a campaign names it: the metric, its checked parameters and its columns."""

    metric: Metric
    values: dict
    columns: tuple  # the metric's columns, or those its function gives for the campaign's scene

    def evaluate(self, samples: 'Samples') -> dict:
        result = self.metric.function(samples, **self.values)
        if not isinstance(result, dict):
            result = {self.columns[0]: result}
        if set(result) != set(self.columns):
            raise ValueError(
                f'metric {self.metric.name} returned columns {sorted(result)}, declared '
                f'{list(self.columns)}'
            )
        n = samples.count
        out = {}
        for column in self.columns:
            array = np.asarray(result[column], dtype=self.metric.dtype)
            if array.shape != (n,):
                raise ValueError(
                    f'metric {self.metric.name}: column {column} has shape {array.shape}, '
                    f'expected ({n},)'
                )
            out[column] = array
        return out


DEFAULT_METRICS = ('final_rates', 'cone_angle', 'flips', 'energy_drift', 'momentum_drift')


def parse_metrics(value, path: str, scene=None, *, commands: bool = False) -> tuple:
    """
    Check a campaign's ``metrics`` list; return a :class:`MetricUse` for each entry.

    ``scene``: the campaign's scene, which gives the columns of a metric that declares them as a
    function of it (None: only metrics with fixed columns); ``commands``: whether the campaign has
    a controller (a metric of its commands is refused without one).
    """
    if not isinstance(value, list) or not value:
        raise FieldError(
            path,
            f'expected a list of metric names (known: {", ".join(sorted(METRICS))}), got '
            f'{shown(value)}',
        )
    uses, seen, columns = [], {}, {}
    for index, entry in enumerate(value):
        where = child(path, index)
        name, parameters = one_key(
            {entry: None} if isinstance(entry, str) else entry, where, METRICS, 'metric'
        )
        if name in seen:
            raise FieldError(where, f'{name} is already metrics[{seen[name]}]')
        seen[name] = index
        found = METRICS[name]
        values = fields(parameters, child(where, name), found.parameters)
        if found.needs_commands and not commands:
            raise FieldError(
                where, f"{name} measures a controller's commands; the campaign has no controller"
            )
        if found.check is not None:
            try:
                found.check(values, scene)
            except ValueError as error:
                raise FieldError(child(where, name), str(error)) from None
        if callable(found.columns):
            try:
                own = tuple(found.columns(scene))
            except ValueError as error:
                raise FieldError(where, f'{name}: {error}') from None
        else:
            own = found.columns
        for column in own:
            if column in columns:
                raise FieldError(where, f"{name}'s column {column} is also {columns[column]}'s")
            columns[column] = name
        uses.append(MetricUse(found, values, own))
    return tuple(uses)


# -- what a metric sees ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Samples:
    """
    ``n`` runs on one time grid.

    Every derived quantity is written out component by component, so a run's numbers are the same
    whichever runs share its chunk.
    """

    times: np.ndarray  # (M,) s, sample 0 is the initial state
    omega_B: np.ndarray  # (n, M, 3) rad/s, body frame
    q_NB: np.ndarray  # (n, M, 4) x, y, z, w
    internal: np.ndarray  # (n, M, s) the effects' own states
    tensor: np.ndarray  # (n, 3, 3) kg m^2, body frame
    moments: np.ndarray  # (n, 3) principal moments (in the order of principal_axes' columns)
    principal_axes: np.ndarray  # (n, 3, 3) columns = principal axes in B
    nominal: 'Samples | None' = None  # the undispersed run (n = 1), for metrics that ask for it
    #: per run, its body with its motion effects (``core.propagators.dynamics.Dynamics``: the
    #: effects' parts of ``internal``, the inertia they carry); None for a torque-free scene, whose
    #: invariants are then the rigid body's, written out component by component
    systems: 'tuple[Dynamics, ...] | None' = None
    #: a stepped plant's sensors and a controller's commands at the samples: ``sensor:TOPIC``,
    #: ``published:TOPIC``, ``command:NAME`` -> ``(n, M, ...)`` (see :meth:`sensor`)
    recorded: dict | None = None

    @property
    def count(self) -> int:
        return self.omega_B.shape[0]

    def sensor(self, topic: str) -> np.ndarray:
        """Return output ``topic``'s rows ``(n, M, width)``, NaN where it sends nothing."""
        return self._recorded(f'sensor:{topic}')

    def published(self, topic: str) -> np.ndarray:
        """Return whether output ``topic`` sends at each sample, ``(n, M)``."""
        return self._recorded(f'published:{topic}')

    def command(self, name: str) -> np.ndarray:
        """
        Return the controller's ``name`` commands (``dipole``, ...) at the samples, ``(n, M, w)``.

        NaN where the law gave none of them (a law that never commands ``name``: all NaN).
        """
        key = f'command:{name}'
        if self.recorded is not None and key not in self.recorded:
            return np.full(self.omega_B.shape[:2] + (1,), np.nan)
        return self._recorded(key)

    def _recorded(self, key: str) -> np.ndarray:
        if self.recorded is None or (key not in self.recorded and key[:8] != 'command:'):
            raise ValueError(f'{key}: not recorded (the metric must say needs_sensors)')
        return self.recorded[key]

    def momentum_B(self) -> np.ndarray:
        """
        Return the whole system's ``H_B`` (n, M, 3), kg m^2/s, body frame.

        The rigid body's ``I w`` with what the effects carry counted as the node counts it
        (``Dynamics.momentum_B``): a wheel's, a damper's, a rotor's own momentum added, the
        inertia a wheel's state holds (``sum Js g g^T``) taken out of ``I``. So ``R(q) H_B`` is
        constant without external torques whatever the motors and friction do.
        """
        if self.systems is None:
            return self._rigid_momentum_B()
        return np.stack(
            [
                system.momentum_B(self.omega_B[i], self.internal[i])
                for i, system in enumerate(self.systems)
            ]
        )

    def momentum_N(self) -> np.ndarray:
        """``H_N = R(q_NB) H_B`` (n, M, 3), the whole system's."""
        return rotate(self.q_NB, self.momentum_B())

    def energy(self) -> np.ndarray:
        """
        Return the whole system's kinetic energy ``T`` (n, M), J.

        ``w . I w / 2`` with the effects' own energy counted as :meth:`momentum_B` counts their
        momentum (a wheel's ``h^2 / (2 Js)`` for its locked ``Js (g . w)^2 / 2``).
        """
        if self.systems is None:
            return 0.5 * dot(self.omega_B, self._rigid_momentum_B())
        return np.stack(
            [
                system.energy(self.omega_B[i], self.internal[i])
                for i, system in enumerate(self.systems)
            ]
        )

    def _rigid_momentum_B(self) -> np.ndarray:
        I, w = self.tensor[:, None, :, :], self.omega_B
        return np.stack(
            [
                I[..., r, 0] * w[..., 0] + I[..., r, 1] * w[..., 1] + I[..., r, 2] * w[..., 2]
                for r in range(3)
            ],
            axis=-1,
        )

    def wheels(self, run: int) -> list:
        """
        Return run ``run``'s reaction wheels: ``(effect, state (M, 2 n))`` per effect, in order.

        ``effect`` a :class:`~torquefree_ros.core.effects.actuators.ReactionWheels` (its
        ``wheel_speeds``, ``stored_momentum_B``, limits), ``state`` its part of ``internal``.
        """
        system = self.systems[run] if self.systems else None
        if system is None:
            return []
        return [
            (effect, self.internal[run][:, part])
            for effect, part in zip(system.effects, system.slices)
            if isinstance(effect, ReactionWheels)
        ]

    def rate_norm(self) -> np.ndarray:
        """``|w|`` (n, M), rad/s."""
        return norm(self.omega_B)


def dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def norm(a):
    return np.sqrt(dot(a, a))


def rotate(q, v):
    """
    Return ``R(q) v`` elementwise over the leading axes.

    It is quaternion.rotate_values on the components: no 3x3 matrix per sample.
    """
    return np.stack(
        quaternion.rotate_values(np.moveaxis(q, -1, 0), np.moveaxis(v, -1, 0)), axis=-1
    )


def _ratio(numerator, denominator):
    """``numerator / denominator``, NaN where the denominator is 0."""
    out = np.full(np.broadcast(numerator, denominator).shape, np.nan)
    np.divide(numerator, denominator, out=out, where=denominator != 0)
    return out


# -- built-in metrics -----------------------------------------------------------------------------
@metric('final_rates', columns=('final_wx', 'final_wy', 'final_wz'), unit='rad/s')
def final_rates(samples):
    """Return the body rates at the last sample, body frame."""
    last = samples.omega_B[:, -1, :]
    return {'final_wx': last[:, 0], 'final_wy': last[:, 1], 'final_wz': last[:, 2]}


@metric(
    'settle_time',
    unit='s',
    parameters={
        'threshold': Param(
            number(positive=True, unit='rad/s'), description='the |w| a run must stay under, rad/s'
        )
    },
)
def settle_time(samples, threshold):
    """
    Return the time of the first sample from which ``|w| < threshold`` at every later sample.

    0 if always; NaN if ``|w|`` is not under it at the last sample.
    """
    over = samples.rate_norm() >= threshold
    M = over.shape[1]
    last_over = np.where(over.any(axis=1), M - 1 - np.argmax(over[:, ::-1], axis=1), -1)
    settled = last_over < M - 1
    return np.where(settled, samples.times[np.minimum(last_over + 1, M - 1)], np.nan)


_AXES = ('major', 'intermediate', 'minor', 'x', 'y', 'z')


def _axis(value, path):
    if isinstance(value, str):
        return choice(*_AXES)(value, path)
    axis = vector(3)(value, path)
    length = float(np.sqrt(axis @ axis))
    if not length > 0:
        raise FieldError(path, 'the axis must not be zero')
    return tuple(float(x) / length for x in axis)


def body_axis(samples: Samples, axis) -> np.ndarray:
    """
    Return the ``(n, 3)`` unit axes in B a metric's ``axis`` names.

    A principal axis (signed so that ``H_B(0)`` is on its positive side), a body axis
    ``x | y | z``, or a given direction.
    """
    n = samples.count
    if not isinstance(axis, str):
        return np.tile(np.asarray(axis, dtype=float), (n, 1))
    if axis in ('x', 'y', 'z'):
        return np.tile(np.eye(3)[('x', 'y', 'z').index(axis)], (n, 1))
    # ascending: minor, intermediate, major
    order = np.argsort(samples.moments, axis=1, kind='stable')
    column = order[:, {'minor': 0, 'intermediate': 1, 'major': 2}[axis]]
    axes = samples.principal_axes[np.arange(n), :, column]
    sign = np.where(dot(axes, samples.momentum_B()[:, 0, :]) < 0.0, -1.0, 1.0)
    return axes * sign[:, None]


@metric(
    'cone_angle',
    unit='rad',
    parameters={
        'axis': Param(
            _axis, 'major', 'major | intermediate | minor | x | y | z | [ax, ay, az] (body frame)'
        )
    },
)
def cone_angle(samples, axis):
    """
    Return the largest angle between ``H`` and a body axis over the run (nutation / cone angle).

    In [0, pi]: ``atan2(|a x H_B|, a . H_B)``. A principal axis is signed so that the angle starts
    below pi/2. NaN for a body at rest.
    """
    a = body_axis(samples, axis)[:, None, :]
    H = samples.momentum_B()
    cross = np.stack(
        [
            a[..., 1] * H[..., 2] - a[..., 2] * H[..., 1],
            a[..., 2] * H[..., 0] - a[..., 0] * H[..., 2],
            a[..., 0] * H[..., 1] - a[..., 1] * H[..., 0],
        ],
        axis=-1,
    )
    angle = np.arctan2(norm(cross), dot(a, H))
    return np.where(norm(H).max(axis=1) > 0.0, angle.max(axis=1), np.nan)


@metric(
    'flips',
    dtype='int64',
    parameters={
        'margin': Param(
            number(minimum=0.0, maximum=89.0, unit='deg'),
            30.0,
            'hysteresis: a flip must carry h_int from above sin(margin) to below -sin(margin), '
            'deg',
        )
    },
)
def flips(samples, margin):
    """
    Count the times the intermediate principal axis turns over relative to ``H``.

    These are Dzhanibekov flips: ``h = H_B . e_int / |H|`` moving from above ``+sin(margin)`` to
    below ``-sin(margin)`` or back (the band between is hysteresis, so a spin about a stable axis,
    whose ``h`` wobbles about 0, counts none). ``e_int`` is the principal axis of the middle moment
    (for an axisymmetric body, the second of the equal pair). 0 for a body at rest.
    """
    n = samples.count
    order = np.argsort(samples.moments, axis=1, kind='stable')
    e_int = samples.principal_axes[np.arange(n), :, order[:, 1]][:, None, :]
    H = samples.momentum_B()
    h = _ratio(dot(H, e_int), norm(H))
    band = math.sin(math.radians(margin))
    state = np.where(h > band, 1, np.where(h < -band, -1, 0))
    M = state.shape[1]
    # latest side taken so far
    last = np.maximum.accumulate(np.where(state != 0, np.arange(M), 0), axis=1)
    held = np.take_along_axis(state, last, axis=1)
    return np.count_nonzero(held[:, 1:] * held[:, :-1] < 0, axis=1)


@metric('energy_drift')
def energy_drift(samples):
    """
    Return the kinetic energy drift, relative: ``max_k |T_k - T_0| / T_0``.

    ``T`` the whole system's (:meth:`Samples.energy`: the body and what its effects carry, a
    wheel's, a damper's). A conservation check for a torque-free scene; otherwise the energy the
    effects put in or take out (a damper's dissipation, the motors' work). NaN when ``T_0`` is 0.
    """
    T = samples.energy()
    return _ratio(np.abs(T - T[:, :1]).max(axis=1), T[:, 0])


@metric('momentum_drift')
def momentum_drift(samples):
    """
    Return the drift of the inertial angular momentum, relative.

    ``max_k |H_N(t_k) - H_N(0)| / |H_N(0)|``, ``H`` the whole system's (:meth:`Samples.momentum_B`:
    a wheel's, a damper's, a rotor's own momentum counted): it checks the rates, the attitude and
    the effects' states together, and is the external torques' impulse otherwise. NaN when
    ``H_N(0)`` is 0.
    """
    H = samples.momentum_N()
    return _ratio(norm(H - H[:, :1, :]).max(axis=1), norm(H[:, 0, :]))


@metric('momentum_peak', unit='N m s')
def momentum_peak(samples):
    """
    Return the largest momentum the reaction wheels store over the run, N m s.

    ``max_k |sum_i Js_i Omega_i g_i|`` over the samples, every ``reaction_wheels`` effect's wheels
    together (``ReactionWheels.stored_momentum_B``: speeds relative to the body): the array's
    momentum envelope a run asks for. NaN for a run without reaction wheels.
    """
    out = np.full(samples.count, np.nan)
    for run in range(samples.count):
        wheels = samples.wheels(run)
        if wheels:
            stored = sum(
                effect.stored_momentum_B(samples.omega_B[run], state) for effect, state in wheels
            )
            out[run] = norm(stored).max()
    return out


def wheel_labels(effects) -> tuple:
    """
    Return a label per reaction wheel of ``effects`` (a scene's motion effects), in order.

    A wheel's name (``ReactionWheels.names``), or ``NAME#m`` when another ``reaction_wheels``
    effect has a wheel of the same name (``m`` counts the motion effects, as a trajectory's
    ``EFFECT#m`` columns do).
    """
    wheels = [
        (m, name)
        for m, effect in enumerate(effects)
        if isinstance(effect, ReactionWheels)
        for name in effect.names
    ]
    names = [name for _, name in wheels]
    return tuple(name if names.count(name) == 1 else f'{name}#{m}' for m, name in wheels)


def _wheel_columns(scene) -> tuple:
    labels = wheel_labels(scene.effects if scene is not None else ())
    if not labels:
        raise ValueError('the scene has no reaction wheels: no wheel to measure')
    return tuple(f'wheel_momentum_peak[{label}]' for label in labels)


@metric('wheel_momentum_peak', columns=_wheel_columns, unit='N m s')
def wheel_momentum_peak(samples):
    """
    Return each reaction wheel's largest stored momentum over the run, N m s, a column per wheel.

    ``max_k |Js_i Omega_i|`` over the samples, ``Omega_i`` the wheel's speed relative to the body
    (``ReactionWheels.wheel_speeds``); the columns ``wheel_momentum_peak[NAME]`` follow the scene's
    wheels (:func:`wheel_labels`). Beside ``momentum_peak`` (the array's vector sum) it tells
    which wheel a run loads most. A scene without reaction wheels is refused when the campaign is
    loaded.
    """
    columns = None
    for run in range(samples.count):
        wheels = samples.wheels(run)
        peaks = np.concatenate(
            [
                (np.abs(effect.spin_inertias * effect.wheel_speeds(samples.omega_B[run], state)))
                .max(axis=0)
                for effect, state in wheels
            ]
        )
        if columns is None:
            labels = wheel_labels(samples.systems[run].effects)
            columns = {
                f'wheel_momentum_peak[{label}]': np.empty(samples.count) for label in labels
            }
        for column, peak in zip(columns, peaks):
            columns[column][run] = peak
    return columns


@metric('saturation_time', unit='s')
def saturation_time(samples):
    """
    Return the time some reaction wheel spends in its speed limit's band, s.

    A sampled measure, as ``/diagnostics`` counts time limited: the interval before sample ``k``
    (``t_k - t_k-1``) counts when at sample ``k`` some wheel's ``|Omega|`` is at least
    ``max_speed - speed_band``, where its motor's accelerating torque fades out (the /diagnostics
    warning's rule); a band entered and left between two samples is not seen. NaN for a run
    without reaction wheels.
    """
    out = np.full(samples.count, np.nan)
    steps = np.diff(samples.times)
    for run in range(samples.count):
        wheels = samples.wheels(run)
        if wheels:
            in_band = np.zeros(samples.times.shape[0], dtype=bool)
            for effect, state in wheels:
                speeds = effect.wheel_speeds(samples.omega_B[run], state)
                in_band |= np.any(np.abs(speeds) >= effect.band_speeds, axis=1)
            out[run] = float(steps[in_band[1:]].sum())
    return out


@metric('nominal_attitude_error', unit='rad', needs_nominal=True)
def nominal_attitude_error(samples):
    """
    Return the largest attitude difference from the nominal (undispersed) run, rad.

    Over the samples: the angle of ``q_nom* ⊗ q``.
    """
    # (1, M, 4) against (n, M, 4): quaternion's element-wise product,
    # so no run depends on its chunk
    return quaternion.angle_between(samples.nominal.q_NB, samples.q_NB).max(axis=1)


def _check_topic(values, scene) -> None:
    topics = [output.topic for output in (scene.outputs if scene is not None else ())]
    if values['topic'] not in topics:
        raise ValueError(
            f'topic: the scene has no output on {values["topic"]!r} (outputs: '
            f'{", ".join(topics) or "none"})'
        )


@metric(
    'sensor_peak',
    needs_sensors=True,
    check=_check_topic,
    parameters={
        'topic': Param(text(), description="the output's topic (its name, by default)"),
        'first': Param(integer(0, 1000), 0, "the vector's first number in the output's row"),
        'count': Param(integer(1, 1000), 3, "the vector's numbers"),
    },
)
def sensor_peak(samples, topic, first, count):
    """
    Return the largest norm of a vector of an output's readings over the run.

    ``|row[first:first + count]|`` over the samples the output sends at (its row as
    ``Plant.sensors().read()`` gives it: the message's numbers in order; by default the first
    three, a magnetometer's field in T, a sun sensor's vector, a magnetorquer_dipole's A m^2), its
    noise, bias and faults included. NaN when it sends at no sample.
    """
    rows = samples.sensor(topic)
    if first + count > rows.shape[2]:
        raise ValueError(f'{topic} rows have {rows.shape[2]} numbers, not {first + count}')
    vector = rows[:, :, first: first + count]
    norms = np.sqrt(np.sum(vector * vector, axis=2))
    sent = samples.published(topic) & np.isfinite(norms)
    return np.where(sent.any(axis=1), np.max(np.where(sent, norms, -np.inf), axis=1), np.nan)


@metric('dipole_duty', needs_commands=True)
def dipole_duty(samples):
    """
    Return the share of the samples at which the commanded dipole drives some rod to its limit.

    Over the campaign's samples but the last (each command holds over the interval after its
    sample): the commanded ``m`` counts when some rod's least-norm share ``|allocation_i . m|``
    reaches its ``max_dipole`` (to 1e-12 relative: a law scaled into the rods lands on it up to
    rounding). In [0, 1]; a sample without a dipole command counts as not saturated. NaN for a
    run without magnetorquers.
    """
    commands = samples.command('dipole')[:, :-1, :]
    out = np.full(samples.count, np.nan)
    for run in range(samples.count):
        system = samples.systems[run] if samples.systems else None
        rods = [e for e in (system.effects if system else ()) if hasattr(e, 'max_dipoles')]
        if not rods or commands.shape[2] != 3 or commands.shape[1] == 0:
            continue
        shares = np.abs(commands[run] @ rods[0].allocation.T) / rods[0].max_dipoles
        with np.errstate(invalid='ignore'):
            saturated = np.max(shares, axis=1) >= 1.0 - 1e-12
        out[run] = np.count_nonzero(saturated) / commands.shape[1]
    return out
