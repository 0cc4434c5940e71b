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
Closed-loop campaigns: a control law run per run on the batched plant, at its own rate.

A campaign file's ``controller:`` section names the law, its rate and its numbers::

    controller:
      law: bdot                     # a built-in law (LAWS), or instead:
      # python: package.module:factory   (a user's law, importable on the Dask workers)
      rate: 1                       # Hz: the plant steps and the law answers at this rate
      parameters: {gain: 1.0e5}     # numbers; each can be dispersed as controller.NAME

The chunk's runs go through one batched ``Plant`` at ``rate`` (:func:`closed_loop`): at every
sample ``k`` from 0 the plant's sensors are read (``Plant.sensors().read()``, bit for bit the
node's rows, each run's own seeds and faults), the law answers, and ``Plant.step(**commands)``
holds its commands over ``[t_k, t_k+1)``. The campaign's own ``rate`` is the grid its metrics and
trajectories see: it must divide the controller's (every ``rate_controller / rate``-th sample is
kept, with the readings and the commands of that sample).

**A law** (the contract a user's factory keeps)::

    def factory(scenes, rate, parameters):   # at the start of every batch of runs
        ...                                   # scenes: the batch's run scenes (core Scene), in
                                              # order; rate: the controller's, Hz; parameters:
                                              # name -> (N,) float array, each run's value
        return law

    law(readings) -> {'dipole': (N, 3), 'torque': (N, 3), 'wheels': (N, n)}   # any of them

``readings`` is the plant's :class:`~torquefree_ros.plant.sensors.SensorReadings` at sample ``k``
(``k``, ``t``, ``rows[topic]`` ``(N, width)``: NaN where the output sends nothing;
``published[topic]`` ``(N,)``), given once a sample in order from ``k = 0``; the commands are
arrays with a row per run, as ``Plant.step`` takes them (an omitted or ``None`` command: the one
in force holds until its timeout). The law must treat each row on its own (elementwise: a run's
commands may not depend on the other runs of its batch, so the table does not depend on
chunking) and may keep state between calls (a new law is made for every batch). A command the
plant refuses (not finite, too large, an actuator the scene lacks) fails the batch's runs one by
one: the run it belongs to is a row ``failed`` with the plant's reason.

**Built-in laws** (:data:`LAWS`): ``bdot``, Stickler & Alfriend's B-dot as
``examples/bdot_detumble_controller.py`` runs it (see :class:`Bdot`): the magnetometer's readings
differenced.
"""

from __future__ import annotations

from dataclasses import dataclass
import importlib
from typing import Callable

import numpy as np

from .dispersions import DrawnThrough, NumberTarget, parse_dispersion
from ..core.checks.schema import child, FieldError, fields, number, Param, shown, text
from ..core.effects.magnetorquers import Magnetorquers
from ..core.timing.grid import MAX_RATE

# how far the campaign's rate may miss dividing the controller's, relative (a float's rounding)
RATE_TOLERANCE = 1e-9


# -- the built-in B-dot law -----------------------------------------------------------------------
class Bdot:
    """
    B-dot from the magnetometer: ``m = -k (B_k - B_j) / (t_k - t_j)``, scaled into the rods.

    Stickler & Alfriend, "Elementary magnetic attitude control system", J. Spacecraft and Rockets
    13(5), 282-287, 1976, as ``examples/bdot_detumble_controller.py`` runs it: ``B_k`` the
    ``magnetometer`` output's field (body frame, T; the first three numbers of its row) at sample
    ``k``, ``B_j`` the one it published before (the previous sample, unless the sensor skipped
    samples: a rate of its own, a dropout); ``k`` the ``gain`` (A m^2 s/T, each run's). The
    dipole is scaled down as a whole (its direction kept) until every rod's least-norm share
    ``|allocation_i . m|`` is within its ``max_dipole`` (each run's rods, dispersed or not), so the
    plant's own per-rod clip never bites; with three orthogonal rods of one ``max_dipole`` this is
    the example's rule. No command before the sensor's second reading (a zero dipole at its first,
    as the example answers), and the last command holds while the sensor sends nothing.
    """

    parameters = {
        'gain': Param(
            number(positive=True, unit='A m^2 s/T'), 1.0e5, 'k of m = -k dB/dt, A m^2 s/T'
        )
    }
    outputs = ('magnetometer',)
    effects = ('magnetorquers',)

    def __init__(self, scenes, rate, parameters):
        (topic,) = {_output(scene, 'magnetometer').topic for scene in scenes}
        self.topic = topic
        rods = [_effect(scene, Magnetorquers) for scene in scenes]
        self.allocation = np.stack([r.allocation for r in rods])  # (N, rods, 3)
        self.max_dipoles = np.stack([r.max_dipoles for r in rods])  # (N, rods)
        self.gain = np.asarray(parameters['gain'], dtype=float)
        count = len(scenes)
        self.last_field = np.full((count, 3), np.nan)
        self.last_t = np.full(count, np.nan)
        self.command = np.zeros((count, 3))

    def __call__(self, readings) -> dict:
        field = readings.rows[self.topic][:, :3]
        sent = np.asarray(readings.published[self.topic]) & np.all(np.isfinite(field), axis=1)
        elapsed = readings.t - self.last_t
        wanted = -self.gain[:, None] * (field - self.last_field) / elapsed[:, None]
        shares = np.abs(np.einsum('nrj,nj->nr', self.allocation, wanted))
        over = np.max(shares / self.max_dipoles, axis=1)
        scaled = np.where((over > 1.0)[:, None], wanted / over[:, None], wanted)
        answered = sent & np.isfinite(self.last_t)
        self.command = np.where(
            answered[:, None], scaled, np.where(sent[:, None], 0.0, self.command)
        )
        self.last_field = np.where(sent[:, None], field, self.last_field)
        self.last_t = np.where(sent, readings.t, self.last_t)
        return {'dipole': self.command}


#: law name -> its class (``cls(scenes, rate, parameters)`` makes the law of a batch)
LAWS = {'bdot': Bdot}


def _output(scene, name: str):
    return next(o for o in scene.outputs if o.name == name)


def _effect(scene, kind):
    return next(e for e in scene.effects if isinstance(e, kind))


# -- the controller section -----------------------------------------------------------------------
@dataclass(frozen=True)
class Controller:
    """A campaign's ``controller:``: the law's maker, its rate and its nominal numbers."""

    name: str  # the built-in law's name, or the python factory's 'module:factory'
    rate: float  # Hz
    parameters: dict  # name -> nominal number

    @property
    def factory(self) -> Callable:
        """Return the law's maker: a built-in law's class, or the imported factory."""
        if self.name in LAWS:
            return LAWS[self.name]
        return import_factory(self.name, 'controller.python')

    def every(self, campaign_rate: float) -> int:
        """Return how many controller samples one campaign sample spans."""
        return round(self.rate / campaign_rate)

    def law(self, scenes, values: dict):
        """Make the law of a batch; ``values``: name -> each run's number (``(N,)``)."""
        return self.factory(scenes, self.rate, values)


@dataclass(frozen=True)
class ControllerTarget(DrawnThrough):
    """A number of the controller's ``parameters`` dispersed per run (``controller.NAME``)."""

    path: str
    name: str
    inner: NumberTarget


def import_factory(reference: str, path: str) -> Callable:
    """Import ``package.module:factory``; a reference that does not resolve is a FieldError."""
    module_name, _, attribute = reference.partition(':')
    if not module_name or not attribute:
        raise FieldError(
            path, f"expected 'package.module:factory', got {shown(reference)}"
        )
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise FieldError(path, f'cannot import {module_name}: {error}') from None
    factory = getattr(module, attribute, None)
    if not callable(factory):
        raise FieldError(path, f'{module_name} has no callable {shown(attribute)}')
    return factory


_SECTION = {
    'law': Param(text(), None, f'a built-in law: {", ".join(LAWS)}'),
    'python': Param(text(), None, "a user's law: 'package.module:factory'"),
    'rate': Param(
        number(positive=True, maximum=MAX_RATE, unit='Hz'),
        description='the rate the plant steps and the law answers at, Hz',
    ),
    'parameters': Param(lambda value, path: value, {}),  # checked by the law below
}


def parse_controller(value, path: str, scene, campaign_rate: float) -> Controller:
    """Check a campaign's ``controller:`` against its scene and its rate."""
    if not isinstance(value, dict):
        raise FieldError(
            path,
            f'expected a mapping with law (or python), rate and parameters, got {shown(value)}',
        )
    values = fields(value, path, _SECTION)
    if (values['law'] is None) == (values['python'] is None):
        raise FieldError(
            path,
            f'name the law once: law ({", ".join(LAWS)}) or python (package.module:factory)',
        )
    rate = values['rate']
    ratio = rate / campaign_rate
    if round(ratio) < 1 or abs(ratio - round(ratio)) > RATE_TOLERANCE * ratio:
        raise FieldError(
            child(path, 'rate'),
            f"{rate:g} Hz is not a whole multiple of the campaign's rate {campaign_rate:g} Hz "
            '(its samples are those the metrics see: the campaign rate must divide the '
            "controller's)",
        )
    given = values['parameters']
    where = child(path, 'parameters')
    if not isinstance(given, dict):
        raise FieldError(where, f'expected a mapping NAME: NUMBER, got {shown(given)}')
    if values['law'] is not None:
        name = values['law']
        if name not in LAWS:
            raise FieldError(
                child(path, 'law'), f'unknown law {shown(name)} (laws: {", ".join(LAWS)})'
            )
        law = LAWS[name]
        parameters = fields(given, where, law.parameters)
        _check_scene(law, scene, child(path, 'law'), name)
    else:
        name = values['python']
        import_factory(name, child(path, 'python'))
        parameters = {
            key: number()(given_value, child(where, key)) for key, given_value in given.items()
        }
    _check_rate(scene, rate, child(path, 'rate'))
    return Controller(name, rate, {k: float(v) for k, v in parameters.items()})


def _check_scene(law, scene, path: str, name: str) -> None:
    """Refuse a built-in law whose sensors or actuators the scene lacks."""
    outputs = [o.name for o in scene.outputs]
    for needed in law.outputs:
        if needed not in outputs:
            raise FieldError(
                path,
                f'{name} reads a {needed} output; the scene has none (outputs: '
                f'{", ".join(outputs) or "none"})',
            )
    effects = [e.name for e in scene.effects]
    for needed in law.effects:
        if needed not in effects:
            raise FieldError(
                path,
                f'{name} commands {needed}; the scene has none (motion effects: '
                f'{", ".join(effects) or "none"})',
            )


def _check_rate(scene, rate: float, path: str) -> None:
    """Refuse a rate the scene's outputs do not divide (the plant reads them at its samples)."""
    for output in scene.outputs:
        try:
            output.every(rate)
        except ValueError as error:
            raise FieldError(path, f'output {output.topic}: {error}') from None


def controller_target(key: str, value, path: str, controller: Controller | None):
    """Parse the dispersion of ``controller.NAME``, a number of the controller's parameters."""
    name = key[len('controller.'):]
    if controller is None:
        raise FieldError(path, 'outside the campaign: it has no controller')
    if name not in controller.parameters:
        known = ', '.join(controller.parameters) or 'none'
        raise FieldError(
            path, f'the controller has no parameter {shown(name)} (its parameters: {known})'
        )
    nominal = controller.parameters[name]
    return ControllerTarget(key, name, NumberTarget(key, nominal, parse_dispersion(value, path)))


# -- the loop -------------------------------------------------------------------------------------
def closed_loop(campaign, scenes: list, values: dict) -> tuple:
    """
    Step the runs' ``scenes`` on one batched plant with the campaign's law; keep its samples.

    ``values``: the controller's parameters, name -> each run's number. Returns ``omega (N, M,
    3)``, ``q (N, M, 4)``, ``internal (N, M, s)`` at the campaign's ``M`` samples and a dict of
    what else they kept: ``sensor:TOPIC`` (each output's rows, ``(N, M, width)``),
    ``published:TOPIC`` (``(N, M)``) and ``command:NAME`` (the law's commands of those samples,
    NaN where it gave none). Without a controller the plant steps at the campaign's rate without
    commands (the scene's own schedules), its sensors read at every sample.
    """
    from ..plant import Plant

    controller = campaign.controller
    rate = controller.rate if controller else campaign.rate
    every = controller.every(campaign.rate) if controller else 1
    plant = Plant(scenes, rate)
    sensors = plant.sensors()
    law = _guarded(controller, controller.law, plant.scenes, values) if controller else None
    count, samples = len(scenes), campaign.samples
    last = (samples - 1) * every
    kept: dict = {}
    states = [[], [], []]
    for k in range(last + 1):
        readings = sensors.read()
        commands = _commands(controller, _guarded(controller, law, readings)) if law else {}
        if k % every == 0:
            state = plant.state
            for part, array in zip(states, state[:3]):
                part.append(array)
            for topic, rows in readings.rows.items():
                kept.setdefault(f'sensor:{topic}', []).append(rows)
                kept.setdefault(f'published:{topic}', []).append(readings.published[topic])
            for name, command in commands.items():
                if command is not None:
                    kept.setdefault(f'command:{name}', {})[k // every] = np.array(
                        command, dtype=float
                    ).reshape(count, -1)
        if k == last:
            break
        plant.step(**{name: c for name, c in commands.items() if c is not None})
    omega, q, internal = (np.stack(part, axis=1) for part in states)
    extra = {}
    for key, parts in kept.items():
        if key.startswith('command:'):
            width = next(iter(parts.values())).shape[1]
            array = np.full((count, samples, width), np.nan)
            for m, rows in parts.items():
                array[:, m] = rows
            extra[key] = array
        else:
            extra[key] = np.stack(parts, axis=1)
    return omega, q, internal, extra


COMMANDS = ('dipole', 'torque', 'wheels')  # what a law may answer: Plant.step's arguments


def _guarded(controller, function, *arguments):
    """
    Call the law (or its factory); its error becomes a RuntimeError naming the law.

    The engine then runs the batch's runs one by one, and each run the law fails on is a row
    ``failed`` with this reason, never the end of the campaign.
    """
    try:
        return function(*arguments)
    except Exception as error:  # noqa: BLE001 - a user's law: pinned on its runs
        raise RuntimeError(
            f'controller {controller.name}: {type(error).__name__}: {error}'
        ) from error


def _commands(controller, commands) -> dict:
    """Check a law's answer: a mapping of ``Plant.step``'s commands (a RuntimeError if not)."""
    if not isinstance(commands, dict) or not set(commands) <= set(COMMANDS):
        raise RuntimeError(
            f'controller {controller.name}: a law answers a dict of {", ".join(COMMANDS)}, '
            f'got {type(commands).__name__}'
            + (f' with {sorted(map(str, commands))}' if isinstance(commands, dict) else '')
        )
    return commands


def law_values(campaign, draws) -> dict:
    """Return the controller's parameters per run: each run's draw, or the nominal number."""
    controller = campaign.controller
    if controller is None:
        return {}
    return {
        name: np.array(
            [
                float(d.values[f'controller.{name}'][0])
                if f'controller.{name}' in d.values
                else nominal
                for d in draws
            ]
        )
        for name, nominal in controller.parameters.items()
    }


def sensor_seed(seed: int, run: int, output: int) -> int:
    """
    Return run ``run``'s seed of the scene's ``output``-th output (``sensor_seeds: per_run``).

    The first 63 bits of ``SeedSequence(seed, spawn_key=(run, output)).generate_state(1,
    uint64)``: a seed the outputs take (``[0, 2^63 - 1]``), depending only on the campaign's seed,
    the run and the output's place among the scene's outputs.
    """
    state = np.random.SeedSequence(seed, spawn_key=(run, output)).generate_state(1, np.uint64)
    return int(state[0]) >> 1


__all__ = ['Bdot', 'Controller', 'LAWS', 'closed_loop', 'parse_controller', 'sensor_seed']
