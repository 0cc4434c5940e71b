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
A run's actuator faults applied to the inputs its commanded effects hold.

An actuator's fault changes the motion, so it acts before the equations, not on rows: it
overrides components of a command hold (:class:`~torquefree_ros.core.commands.hold.Override`) on
the run's sample intervals ``[t_k, t_k+1)``, ``k`` from the first sample at or after ``start`` to
the last before the first at or after ``end`` (the sensors' rule, on the run's grid). A commanded
effect's inputs change at sample times only and every piece starts at one, so the hold is where
both propagation paths, the outputs reporting the inputs and a replay read them.

``wheel_stuck``: the wheel's component of its ``reaction_wheels``' hold is its ``off`` value (zero
torque; a speed drive off, NaN) on the window. ``magnetorquer_stuck`` and ``torque_stuck``: the
three components of each ``magnetorquers``' (``torque_command``'s) hold are its ``value``, or what
held on the interval before the window. ``torque_error`` and ``wheel_torque_error``: the held
torque (each ``torque_command``'s three components, in its frame; the wheel's motor torque) is
``scale * value + bias``; a wheel's before its limits, which the equations apply to what the hold
gives (a faulted wheel still saturates and stops at its speed limit). In speed mode the wheel's
speed loop's output is: the hold's set-point stays, and the override (no component, the wheel's
index as its value) is read by ``ReactionWheels.loop_errors`` into the equations. ``torque_noise``,
``wheel_torque_noise`` and ``dipole_noise``: :class:`SeededNoise` is added to the held input
(each ``torque_command``'s torque on the fault's topic, the wheel's motor torque, each
``magnetorquers``' dipole asked for), the normals of interval ``k`` keyed by the fault's ``seed``
and place (:mod:`.draws`), so every reader of the hold adds the same numbers.

Faults set while a run goes on (:meth:`ActuatorFaults.replace`) act from a given sample on, as
the sensors' do: a window that started earlier starts there; a fault equal to the one at its
place before goes on as it was (a stuck dipole keeps the value it read).
"""

from __future__ import annotations

import numpy as np

from .draws import fault_key, keyed_uniforms, normals
from .schedule import ACTUATOR_FAULTS, ERROR_FAULTS, Fault, NOISE_FAULTS, TORQUE_FAULTS
from ..checks.schema import child, FieldError
from ..commands.hold import Override
from ..timing.grid import first_sample_at_or_after


def actuator_faults(faults) -> tuple[Fault, ...]:
    """Return the actuators' faults among ``faults``."""
    return tuple(fault for fault in faults if fault.kind in ACTUATOR_FAULTS)


def targets(fault: Fault, effects) -> list[tuple]:
    """
    Return ``(effect, components)`` for each of ``effects`` a fault acts on.

    ``FieldError`` at the fault's path when the effects have nothing for it: no commanded effect
    of its kind, an unknown wheel.
    """
    name = ACTUATOR_FAULTS[fault.kind]
    of_kind = [effect for effect in effects if effect.name == name]
    commanded = [effect for effect in of_kind if getattr(effect, 'mode', 'torque') != 'schedule']
    if not commanded:
        raise FieldError(
            fault.path,
            f'the scene has no {name} to act on'
            if not of_kind
            else f'its {name} are in mode schedule: a fault acts on commanded wheels (mode '
            'torque or speed)',
        )
    if fault.kind in TORQUE_FAULTS:
        return [(effect, (0, 1, 2)) for effect in _on_topic(fault, commanded)]
    if fault.kind in ('magnetorquer_stuck', 'dipole_noise'):
        return [(effect, (0, 1, 2)) for effect in commanded]
    found = [
        (effect, (effect.names.index(fault.wheel),))
        for effect in commanded
        if fault.wheel in effect.names
    ]
    if len(found) != 1:
        known = ', '.join(n for effect in commanded for n in effect.names)
        raise FieldError(
            child(fault.path, 'wheel'),
            f'{fault.wheel[:80]!r} is not a commanded wheel of the scene (wheels: {known[:200]})'
            if not found
            else f'{fault.wheel[:80]!r} names wheels of {len(found)} reaction_wheels effects',
        )
    if found[0][0].mode == 'hold':  # (exact only while held: no state to carry a drift)
        raise FieldError(
            fault.path,
            f'the wheel {fault.wheel[:80]!r} is in mode hold, held at its speed by an ideal '
            'drive: a drive that stops or errs would change that speed (a momentum step, or a '
            "coast), which a held array has no state to carry; a drive's faults act in mode "
            'torque or speed',
        )
    if fault.kind == 'wheel_torque_noise' and found[0][0].mode != 'torque':
        raise FieldError(
            fault.path,
            f'the wheel {fault.wheel[:80]!r} is in mode {found[0][0].mode}: its motor torque is '
            "its speed loop's; a torque noise acts on commanded motor torques (mode torque)",
        )
    return found


def _on_topic(fault: Fault, commanded: list) -> list:
    """
    Return the ``torque_command`` effects on a torque fault's ``topic``.

    Without one, the scene's only topic; ``FieldError`` at the fault's path when it has several,
    or at its ``topic`` when no effect is on it.
    """
    topics = sorted({effect.topic for effect in commanded})
    listed = ', '.join(topic[:80] for topic in topics)[:300]
    if fault.topic is None:
        if len(topics) > 1:
            raise FieldError(
                fault.path,
                f'the scene has torque_command effects on {len(topics)} topics ({listed}): give '
                "'topic' to say which one the fault acts on",
            )
        return commanded
    chosen = [effect for effect in commanded if effect.topic == fault.topic]
    if not chosen:
        raise FieldError(
            child(fault.path, 'topic'),
            f'{fault.topic[:80]!r} is not the topic of a torque_command of the scene (topics: '
            f'{listed})',
        )
    return chosen


def check_actuator_faults(faults, effects) -> None:
    """Refuse (``FieldError`` with the field path) actuator faults ``effects`` cannot take."""
    for fault in actuator_faults(faults):
        targets(fault, effects)


class ActuatorFaults:
    """
    A run's actuator faults on its command holds.

    ``effects``: the run's effects, bound (each commanded one with its hold); ``rate``: the run's
    sample rate, Hz.
    """

    def __init__(self, faults, effects, rate: float):
        self.effects = tuple(effects)
        self.rate = float(rate)
        self.windows: tuple[tuple[Fault, int, int | None], ...] = ()  # (fault, first, stop)
        self.replace(faults, 0)

    @property
    def faults(self) -> tuple[Fault, ...]:
        return tuple(fault for fault, _, _ in self.windows)

    def replace(self, faults, from_sample: int) -> None:
        """
        Put the actuator faults among ``faults`` in force from interval ``from_sample`` on.

        ``FieldError`` (and nothing changed) when one names what the run has not.
        """
        faults = actuator_faults(faults)
        check_actuator_faults(faults, self.effects)
        before = {fault.index: (fault, first, stop) for fault, first, stop in self.windows}
        windows = []
        for fault in faults:
            kept = before.get(fault.index)
            if kept is not None and kept[0] == fault:
                windows.append(kept)
                continue
            first = max(first_sample_at_or_after(fault.start, self.rate), from_sample)
            stop = None if fault.end is None else first_sample_at_or_after(fault.end, self.rate)
            if stop is None or first < stop:
                windows.append((fault, first, stop))
        self.windows = tuple(windows)
        overrides = {id(effect): [] for effect in self.effects}
        for fault, first, stop in self.windows:
            for effect, components in targets(fault, self.effects):
                overrides[id(effect)].append(_override(fault, first, stop, effect, components))
        for effect in self.effects:
            if getattr(effect, 'hold', None) is not None:
                effect.hold.override(overrides[id(effect)])

    def active(self, k: int) -> list[Fault]:
        """Return the faults acting on interval ``k`` (from sample ``k`` to the next)."""
        return [
            fault
            for fault, first, stop in self.windows
            if first <= k and (stop is None or k < stop)
        ]


def _override(fault: Fault, first: int, stop, effect, components: tuple) -> Override:
    """Return what ``fault`` does to ``effect``'s hold on its window."""
    if fault.kind == 'wheel_torque_error' and effect.mode == 'speed':
        # the speed loop's output, not the set-point: no component changed, the wheel's index
        # as the value (ReactionWheels.loop_errors reads it)
        return Override(first, stop, (), components, fault.scale, fault.bias)
    if fault.kind in ERROR_FAULTS:
        return Override(first, stop, components, None, fault.scale, fault.bias)
    if fault.kind in NOISE_FAULTS:
        noise = SeededNoise(fault.seed, fault.index, fault.noise[: len(components)])
        return Override(first, stop, components, None, noise=noise)
    if fault.kind == 'wheel_stuck':
        off = tuple(float(effect.hold.off[i]) for i in components)
        return Override(first, stop, components, off)
    return Override(first, stop, components, fault.value)


class SeededNoise:
    """
    A white noise of 1-sigma ``sigma`` (one a component) on the run's sample intervals.

    ``noise(k)``: the normals of fault ``index`` seeded ``seed`` at sample ``k`` (:mod:`.draws`,
    the sensors' ``noise`` fault's), the first ``len(sigma)`` of its three, times ``sigma``. Equal
    when its seed, index and sigma are: a fault kept across a change of the faults is the same.
    The noise of :data:`AHEAD` intervals is drawn at a time (a sample's draws depend on its index
    alone, so drawing ahead changes none).
    """

    AHEAD = 64

    def __init__(self, seed: int, index: int, sigma: tuple):
        self.seed, self.index, self.sigma = int(seed), int(index), tuple(sigma)
        self._key = fault_key(self.seed, self.index)
        self._scale = np.array(self.sigma)
        self._first = -self.AHEAD - 1  # the first interval drawn ahead
        self._ahead = np.empty((0, self._scale.size))

    def __call__(self, k: int) -> np.ndarray:
        offset = k - self._first
        if not 0 <= offset < self.AHEAD:
            drawn = self._scale * normals(keyed_uniforms(self._key, k, k + self.AHEAD))[
                :, : self._scale.size
            ]
            drawn.flags.writeable = False
            self._first, self._ahead, offset = k, drawn, 0
        return self._ahead[offset]

    def _identity(self) -> tuple:
        return self.seed, self.index, self.sigma

    def __eq__(self, other) -> bool:
        return isinstance(other, SeededNoise) and self._identity() == other._identity()

    def __hash__(self) -> int:
        return hash(self._identity())

    def __repr__(self) -> str:
        return f'SeededNoise(seed={self.seed}, index={self.index}, sigma={self.sigma})'


__all__ = ['ActuatorFaults', 'SeededNoise', 'actuator_faults', 'check_actuator_faults', 'targets']
