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
A scene as a plant a controller steps in process: one body, or a batch advanced together.

``Plant(scene, rate)`` holds the body at sample ``k`` (time ``t_k = k / rate``); ``step(torque)``
holds ``torque`` over ``[t_k, t_k+1)`` under the ``torque_command`` effect's rules (its frame,
``max_torque``, ``timeout``: a command holds until ``timeout`` simulated seconds after its sample,
then the torque is zero) and returns the state at ``k + 1``; ``step(wheels=...)`` holds the
commanded ``reaction_wheels``' inputs the same way (a motor torque, N m, or a speed set-point,
rad/s, per wheel by the effect's ``mode``; after ``timeout`` the motors are off);
``step(dipole=...)`` holds the body dipole (A m^2) a scene's ``magnetorquers`` are commanded with
(``magnetorquer_command``'s rules: refused when not finite or a component exceeds
``max_command``; zero after ``timeout``), the rods applying its least-norm allocation, each rod
clipped to its ``max_dipole`` (``Magnetorquers.applied_dipole``). ``Plant([scene, ...], rate)``
holds N bodies, each with its own inertia, initial state and effect parameters; ``step`` takes
``(N, 3)`` torques, ``(N, n)`` wheel inputs and ``(N, 3)`` dipoles and one compiled call advances
every body. A body of a batch is bit for bit the same body alone: both run the same kernel
(``motion_kernels.dop853_outputs_batch``) with the same numbers.

A scene's actuator faults (``core.faults.actuators``: a stuck wheel, a wheel's torque error, stuck
magnetorquers, a stuck or erring commanded torque) act on each body's inputs on the sample
intervals of their windows, as in the node: the windows are ``ActuatorFaults``' and the inputs
are changed by the hold's own rule (``commands.hold.overridden``), body by body (the bodies of a
batch may have different faults).

The plant integrates with DOP853 at the scene's ``accuracy`` (``auto``'s settings) through
``drivers.DOP853Bodies``, the engine the ``dop853`` propagator runs with one body: the node's
closed loop and its offline replay run the same object (the stepping starts again at every sample
when the scene takes commands, and at every switch of a torque schedule, each body of a batch at
its own).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..core.commands.hold import overridden, timed_out, torque_refusal, torque_refusals
from ..core.compiled import drivers
from ..core.compiled import motion_kernels as kernels
from ..core.effects.actuators import ReactionWheels
from ..core.effects.commands import command_inputs
from ..core.effects.magnetorquers import dipole_too_large, Magnetorquers
from ..core.faults.actuators import ActuatorFaults
from ..core.propagators import ATOL_PER_RTOL, DEFAULT_ACCURACY, MAX_STEPS_PER_SAMPLE
from ..core.scene.loader import load_scene, Scene
from ..core.timing.grid import check_rate, sample_stamp_ns


class PlantState(NamedTuple):
    """
    A sample: body rates, attitude, the effects' own states and the wheels' speeds.

    Body rates (rad/s, body frame), attitude ``q_NB`` (x, y, z, w), the effects' own states (a
    damper's rate; reaction wheels: a pair per wheel, its absolute axial momentum ``Js (Omega +
    g . w)`` N m s and its angle rad) and each reaction wheel's speed ``Omega`` relative to the
    body (rad/s, the wheels of every ``reaction_wheels`` effect in scene order; none without
    wheels); a batch has a leading axis of bodies.
    """

    omega_B: np.ndarray
    q_NB: np.ndarray
    internal: np.ndarray
    wheel_speeds: np.ndarray | None = None


class Plant:
    """
    A scene, or a batch of scenes, stepped in process (see the module's docstring).

    ``scene``: a :class:`Scene`, a scene file's path or a library scene's name, or a list of them
    (a batch, even of one).
    """

    def __init__(self, scene, rate: float):
        self.batch = isinstance(scene, (list, tuple))
        scenes = (
            [_as_scene(s, f'scene[{i}]') for i, s in enumerate(scene)]
            if self.batch
            else [_as_scene(scene, 'scene')]
        )
        if not scenes:
            raise ValueError('scene: a batch needs at least one scene')
        self.rate = check_rate(rate)
        self.scenes = scenes
        self._build()

    # -- state -----------------------------------------------------------------------------------
    @property
    def size(self) -> int:
        """How many bodies."""
        return len(self.scenes)

    @property
    def t(self) -> float:
        return self.k / self.rate

    @property
    def state(self) -> PlantState:
        """Return the state at sample ``k`` (copies)."""
        return self._shaped(self._sample)

    @property
    def takes_torque(self) -> bool:
        return self._commands is not None

    @property
    def takes_wheels(self) -> bool:
        """Whether the scene has commanded ``reaction_wheels`` (``step``'s ``wheels``)."""
        return self._wheels is not None

    @property
    def takes_dipole(self) -> bool:
        """Whether the scene has ``magnetorquers`` (``step``'s ``dipole``)."""
        return self._dipoles is not None

    @property
    def wheel_effect(self) -> ReactionWheels | None:
        """Return the commanded ``reaction_wheels`` of scene 0 (names, mode, limits), or None."""
        return self._wheels.effect if self._wheels is not None else None

    def sensors(self):
        """Return the reader of the scene's outputs at the plant's samples (``PlantSensors``)."""
        from .sensors import PlantSensors

        return PlantSensors(self)

    # -- stepping --------------------------------------------------------------------------------
    def step(self, torque=None, wheels=None, dipole=None) -> PlantState:
        """
        Hold the commands given over ``[t_k, t_k+1)`` and return the state at ``k + 1``.

        ``torque``: N m, in the ``torque_command`` effect's frame; ``(3,)``, or ``(N, 3)`` for a
        batch. ``wheels``: the commanded ``reaction_wheels``' input per wheel in its order, a motor
        torque (N m, mode ``torque``; clipped by the wheel) or a speed set-point (rad/s, mode
        ``speed``); ``(n,)``, or ``(N, n)`` for a batch. ``dipole``: the body dipole (A m^2, body
        frame) the ``magnetorquers`` are asked for; ``(3,)``, or ``(N, 3)`` for a batch; the rods
        apply its least-norm allocation, each rod clipped to its ``max_dipole``. ``None``: no new
        command (the one in force holds until its timeout). A refused torque, wheel input or dipole
        raises ``ValueError`` and changes nothing.
        """
        if torque is not None:
            torque = self._checked_torque(torque)
        if wheels is not None:
            wheels = self._checked_wheels(wheels)
        if dipole is not None:
            dipole = self._checked_dipole(dipole)
        stamp = sample_stamp_ns(self.k, self.rate)
        if torque is not None:
            self._commands.accept(torque, stamp)
        if wheels is not None:
            self._wheels.accept(wheels, stamp)
        if dipole is not None:
            self._dipoles.accept(dipole, stamp)
        self._advance(np.array([(self.k + 1) / self.rate]))
        return self.state

    def run(self, duration: float) -> PlantState:
        """
        Advance ``floor(duration * rate)`` samples without new commands and return their states.

        The states have a leading axis of samples (after the bodies' axis, for a batch).
        """
        if (
            isinstance(duration, bool)
            or not isinstance(duration, (int, float))
            or not duration >= 0
        ):
            raise ValueError(
                f'duration: expected a non-negative number of seconds, got {duration!r}'
            )
        count = int(np.floor(duration * self.rate + 1e-9))
        # the hold's timeout may end within the run: one interval a call
        if self._commanded:
            samples = [self._advance(np.array([(self.k + 1) / self.rate])) for _ in range(count)]
            rows = (
                np.concatenate(samples, axis=1)
                if samples
                else np.empty((self.size, 0, self._bodies.width))
            )
        else:
            rows = self._advance(np.arange(self.k + 1, self.k + 1 + count) / self.rate)
        return self._shaped(rows, samples_axis=True)

    def reset(self) -> PlantState:
        """Back to sample 0 of every body's scene, without commands."""
        self._build()
        return self.state

    # -- internals -------------------------------------------------------------------------------
    def _build(self) -> None:
        kernels.compile_kernels()
        propagators = []
        for scene in self.scenes:
            accuracy = DEFAULT_ACCURACY if scene.accuracy is None else scene.accuracy
            propagators.append(
                scene.propagator('dop853', rtol=accuracy, atol=accuracy * ATOL_PER_RTOL)
            )
        layouts = [_layout(p) for p in propagators]
        for index, layout in enumerate(layouts):
            if layout != layouts[0]:
                raise ValueError(
                    f'scene[{index}]: its motion effects ({", ".join(layout) or "none"}) '
                    f"differ from scene[0]'s ({', '.join(layouts[0]) or 'none'}): a batch steps "
                    'bodies of one kind (make one plant per kind)'
                )
        count = len(propagators)
        self._bodies = drivers.DOP853Bodies(propagators, MAX_STEPS_PER_SAMPLE)
        self._sample = self._bodies.ys.copy()[:, None, :]
        self.k = 0
        self._failed: str | None = None
        self._speeds = _WheelSpeeds.of(propagators)
        commands = [
            [e for e in command_inputs(p.effects) if e.name == 'torque_command']
            for p in propagators
        ]
        wheels = [
            [e for e in command_inputs(p.effects) if isinstance(e, ReactionWheels)]
            for p in propagators
        ]
        if any(len(c) > 1 for c in commands):
            raise ValueError(
                'scene: more than one torque_command effect; the plant takes one torque per body'
            )
        if any(len(w) > 1 for w in wheels):
            raise ValueError(
                'scene: more than one commanded reaction_wheels effect; the plant takes one '
                'input per wheel of one'
            )
        rods = [[e for e in p.effects if isinstance(e, Magnetorquers)] for p in propagators]
        if any(len(r) > 1 for r in rods):
            raise ValueError(
                'scene: more than one magnetorquers effect; the plant takes one dipole per body'
            )
        # the commanded wheels' inputs go after the torques, at their momenta's places, and the
        # applied dipole in the magnetorquers' slot at the end
        width = drivers.held_width(propagators[0].dynamics) if wheels[0] or rods[0] else 6
        self._command_helds = np.zeros((count, width))
        self._wheels = _WheelInputs([w[0] for w in wheels], propagators[0]) if wheels[0] else None
        if self._wheels is not None and self._wheels.error_columns is not None:
            self._command_helds[:, self._wheels.error_columns] = self._wheels.no_error
        self._commands = _TorqueInputs([c[0] for c in commands]) if commands[0] else None
        self._dipoles = _DipoleInputs([r[0] for r in rods], propagators[0]) if rods[0] else None
        inputs = [i for i in (self._commands, self._wheels, self._dipoles) if i is not None]
        self._commanded = bool(inputs)
        # each body's actuator faults: their windows put overrides on its effects' holds, which
        # the plant applies to that body's inputs (sensor faults act on outputs, not on motion)
        self._faulted_inputs = []
        for body, (scene, propagator) in enumerate(zip(self.scenes, propagators)):
            if ActuatorFaults(scene.faults, propagator.effects, self.rate).windows:
                self._faulted_inputs += [
                    _FaultedInput(i, body) for i in inputs if i.effects[body].hold.overrides
                ]

    def _checked_torque(self, torque) -> np.ndarray:
        commands = self._commands
        if commands is None:
            raise ValueError(
                'torque: the scene takes no torque (it names no torque_command effect)'
            )
        shape = (self.size, 3) if self.batch else (3,)
        try:
            values = np.array(torque, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f'torque: expected numbers of shape {shape}, got {torque!r}'[:300]
            ) from None
        if values.shape != shape:
            raise ValueError(f'torque: expected shape {shape}, got {values.shape}')
        values = values.reshape(self.size, 3)
        if not self.batch and not torque_refusal(values[0].tolist(), commands.max_torque[0]):
            return values  # (one body: the hold's rule on one command, on Python floats)
        not_finite, over = torque_refusals(values, commands.max_torque)
        if not_finite.any():
            b = int(np.argmax(not_finite))
            raise ValueError(f'torque: not finite (body {b}): {values[b].tolist()}')
        if over.any():
            b = int(np.argmax(over))
            raise ValueError(
                f'torque: a component exceeds max_torque {commands.max_torque[b]:g} N m '
                f'(body {b}): {values[b].tolist()}'
            )
        return values

    def _checked_wheels(self, wheels) -> np.ndarray:
        commands = self._wheels
        if commands is None:
            raise ValueError(
                'wheels: the scene takes no wheel commands (it has no reaction_wheels in mode '
                'torque or speed)'
            )
        n = commands.columns.size
        shape = (self.size, n) if self.batch else (n,)
        try:
            values = np.array(wheels, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f'wheels: expected numbers of shape {shape}, got {wheels!r}'[:300]
            ) from None
        if values.shape != shape:
            raise ValueError(
                f'wheels: expected shape {shape} (one {commands.unit} per wheel: '
                f'{", ".join(commands.effect.names)}), got {values.shape}'
            )
        values = values.reshape(self.size, n)
        if not self.batch and all(map(math.isfinite, values[0].tolist())):
            return values  # (one body: on Python floats, cheaper than numpy's per-call cost)
        not_finite = ~np.all(np.isfinite(values), axis=1)
        if not_finite.any():
            b = int(np.argmax(not_finite))
            raise ValueError(f'wheels: not finite (body {b}): {values[b].tolist()}')
        return values

    def _checked_dipole(self, dipole) -> np.ndarray:
        commands = self._dipoles
        if commands is None:
            raise ValueError('dipole: the scene takes no dipole (it has no magnetorquers)')
        shape = (self.size, 3) if self.batch else (3,)
        try:
            values = np.array(dipole, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f'dipole: expected numbers of shape {shape}, got {dipole!r}'[:300]
            ) from None
        if values.shape != shape:
            raise ValueError(
                f'dipole: expected shape {shape} (A m^2, body frame), got {values.shape}'
            )
        values = values.reshape(self.size, 3)
        # the node's rules, the hold's (not finite) and the effect's (too large): a batch's bodies
        # screened at once, then the first one flagged (one body: itself) by the rules themselves
        if self.batch:
            not_finite, too_large = torque_refusals(values, commands.max_torque)
            too_large |= ~not_finite & (np.abs(values).max(axis=1) > commands.max_command)
            suspects = np.flatnonzero(not_finite | too_large)[:1].tolist()
        else:
            suspects = [0]
        for b in suspects:
            row, effect = values[b].tolist(), commands.effects[b]
            reason = torque_refusal(row, effect.hold.max_torque) or dipole_too_large(
                row, effect.values['max_command']
            )
            if reason:
                raise ValueError(
                    f'dipole: {reason}{f" (body {b})" if self.batch else ""}: {row}'[:300]
                )
        return values

    def _hold(self) -> None:
        """
        Set the commanded inputs over ``[t_k, t_k+1)`` for every body.

        The torque in force (zero once it timed out), in its frame, added to the scene's constant
        torques; the wheels' inputs in force (``off`` once timed out: zero torque, a drive off) and
        the dipole the rods apply at their places (CommandHold's rule, for every body at once);
        then, body by body, what its actuator faults make of them on this interval.
        """
        now = sample_stamp_ns(self.k, self.rate)
        helds = self._command_helds
        for inputs in (self._commands, self._wheels, self._dipoles):
            if inputs is not None:
                helds[:, inputs.columns] = inputs.in_force(now)
        for faulted in self._faulted_inputs:
            faulted.write(self.k, now, helds)

    def _advance(self, times: np.ndarray) -> np.ndarray:
        if self._failed is not None:
            raise RuntimeError(
                f'plant: stopped at sample {self.k} ({self._failed}); reset() starts it again'
            )
        self._hold()
        sample_rate = self.rate if self._commanded else 0.0
        out = self._bodies.advance(times, self._command_helds, sample_rate)
        if np.count_nonzero(self._bodies.status != kernels.DONE):
            self._fail(int(np.flatnonzero(self._bodies.status != kernels.DONE)[0]), times)
        self.k += times.size
        self._sample = out[:, -1:, :].copy() if times.size else self._sample
        return out

    def _fail(self, body: int, times: np.ndarray):
        """
        Stop the plant and raise: a body could not reach its sample.

        The kernels' state is mid-step for some bodies, so the plant refuses to go on until
        ``reset()``; ``state`` stays the last sample reached.
        """
        bodies = self._bodies
        t = float(times[min(int(bodies.reached[body]), times.size - 1)])
        error = drivers.dop853_error(
            int(bodies.status[body]), bodies.propagators[body], t, bodies.solvers[body]
        )
        self._failed = f'{"body %d: " % body if self.batch else ""}{error}'
        raise error

    def _shaped(self, rows: np.ndarray, samples_axis: bool = False) -> PlantState:
        rows = rows if samples_axis else rows[:, -1, :]
        speeds = self._speeds(rows)
        rows = rows.copy() if self.batch else rows[0].copy()  # (one copy; its parts are views)
        if not self.batch:
            speeds = speeds[0]
        return PlantState(rows[..., :3], rows[..., 3:7], rows[..., 7:], speeds)


#: the stamp of "no command yet": timed out at every sample of the run
_NEVER_NS = int(np.iinfo(np.int64).min // 2)


class _Inputs:
    """
    A commanded input of every body: the last command and the hold's timeout rule on it.

    ``effects``: each body's effect (its hold: timeout, ``off``, a fault's overrides);
    ``columns``: where the input goes in the held inputs; ``asked`` ``(N, n)``: the last command
    per body, as the hold keeps it; ``held``: what the kernels read of it (the same array, or the
    dipole the rods apply); ``off``: what they read while none is in force. A step gives every
    body its command at once, so one stamp serves them all.
    """

    def __init__(self, effects, columns, off, width: int, applies=None):
        self.effects = effects
        self.columns = columns
        self.off = off
        self.asked = np.zeros((len(effects), width))
        self.applies = applies  # each body's map from asked to held (None: the same)
        self.held = self.asked if applies is None else np.array(off, dtype=float)
        self.timeout_ns = np.array([e.hold.timeout_ns for e in effects], dtype=np.int64)
        self.shortest_timeout_ns = int(self.timeout_ns.min())
        self.stamp_ns = _NEVER_NS

    def accept(self, values: np.ndarray, stamp_ns: int) -> None:
        """Hold ``values`` (a row per body) from the sample stamped ``stamp_ns``."""
        self.asked[:] = values
        if self.applies is not None:
            self.held[:] = self.applied(values)
        self.stamp_ns = stamp_ns

    def applied(self, values: np.ndarray) -> np.ndarray:
        """Return what the kernels read for ``values`` (a row per body), body by body."""
        return np.array([apply(row) for apply, row in zip(self.applies, values)])

    def in_force(self, now_ns: int) -> np.ndarray:
        """Return what every body's kernels read on the interval stamped ``now_ns``."""
        if not timed_out(now_ns, self.stamp_ns, self.shortest_timeout_ns):
            return self.held  # (every body's command in force: the usual case, no array work)
        in_force = ~timed_out(now_ns, self.stamp_ns, self.timeout_ns)
        return np.where(in_force[:, None], self.held, self.off)


class _TorqueInputs(_Inputs):
    """Each body's ``torque_command``: a torque in the body or the inertial frame's columns."""

    def __init__(self, effects):
        super().__init__(effects, slice(3, 6) if effects[0].inertial else slice(0, 3), 0.0, 3)
        self.max_torque = np.array([e.hold.max_torque for e in effects])


class _WheelInputs(_Inputs):
    """Each body's commanded ``reaction_wheels``: an input per wheel, at its momentum's column."""

    def __init__(self, effects, propagator):
        effect = effects[0]
        dynamics = propagator.dynamics
        (part,) = [p for e, p in zip(dynamics.effects, dynamics.slices) if e is effect]
        # the momentum h_i of wheel i is state 2 i of its effect: its input goes there; while none
        # is in force, zero torque or a drive off (NaN)
        columns = kernels.HELD_TORQUES + part.start + 2 * np.arange(effect.count)
        super().__init__(effects, columns, np.array(effect.off), effect.count)
        self.effect = effect  # scene 0's (names, mode)
        # speed mode: the drives' torque errors (scale, bias) in the effect's slot, none acting
        # (1, 0) unless a fault writes them (_FaultedInput)
        slots = drivers.held_slots(dynamics)
        (slot,) = [s for e, s in zip(dynamics.effects, slots) if e is effect]
        self.error_columns = (
            None if slot is None else slot + np.arange(effect.held_slot_size)
        )
        self.no_error = np.tile([1.0, 0.0], effect.count)
        self.unit = 'speed set-point (rad/s)' if effect.mode == 'speed' else 'motor torque (N m)'


class _DipoleInputs(_Inputs):
    """Each body's ``magnetorquers``: the dipole asked for, and the one its rods apply."""

    def __init__(self, effects, propagator):
        dynamics = propagator.dynamics
        (slot,) = [
            s for e, s in zip(dynamics.effects, drivers.held_slots(dynamics)) if e is effects[0]
        ]
        applies = [e.applied_dipole for e in effects]
        off = np.array([apply(e.hold.off) for apply, e in zip(applies, effects)])
        columns = slot + np.arange(effects[0].held_slot_size)
        super().__init__(effects, columns, off, 3, applies)
        self.max_torque = np.array([e.hold.max_torque for e in effects])
        self.allocations = None
        self.max_command = np.array([e.values['max_command'] for e in effects])
        if len({len(e.max_dipoles) for e in effects}) > 1:
            return  # rods of different counts: body by body (_Inputs.applied)
        # each body's rods: (N, rods, 3) allocations and axes, (N, rods, 1) largest dipoles
        self.allocations = np.stack([e.allocation for e in effects])
        self.axes = np.stack([e.axes for e in effects])
        self.max_dipoles = np.stack([e.max_dipoles for e in effects])[:, :, None]

    def applied(self, values: np.ndarray) -> np.ndarray:
        """
        Return the dipole each body's rods apply for ``values`` (``Magnetorquers.applied_dipole``).

        Its operations for every body at once: a stacked matmul calls the same BLAS routine per
        body as the effect's one-body products (matrix @ vector, then vector @ matrix), and the
        clip is element by element, so each row is the effect's floats.
        """
        if self.allocations is None or len(values) == 1:
            return super().applied(values)  # (one body: the effect's, which keeps its last)
        least_norm = np.matmul(self.allocations, values[:, :, None])
        rods = np.clip(least_norm, -self.max_dipoles, self.max_dipoles)
        return np.matmul(np.swapaxes(rods, 1, 2), self.axes)[:, 0, :]


class _FaultedInput:
    """
    A body's input its actuator faults change: the overrides on its effect's hold, applied.

    By the hold's rule (``overridden``) on what the hold would give (the command in force, or
    ``off``), keeping what held on the interval before a window that holds it.
    """

    def __init__(self, inputs: _Inputs, body: int):
        self.inputs, self.body = inputs, body
        self.hold = inputs.effects[body].hold
        self.timeout_ns = int(inputs.timeout_ns[body])
        self.previous = self.hold.off  # what held on the interval before (off before sample 0)
        self.kept: dict = {}

    def write(self, k: int, now_ns: int, helds: np.ndarray) -> None:
        """Write the body's input on interval ``k`` (stamped ``now_ns``) into ``helds``."""
        inputs, body = self.inputs, self.body
        asked = (
            self.hold.off
            if timed_out(now_ns, inputs.stamp_ns, self.timeout_ns)
            else inputs.asked[body].copy()
        )
        values = overridden(asked, k, self.hold.overrides, self._kept)
        self.previous = values
        helds[body, inputs.columns] = (
            values if inputs.applies is None else inputs.applies[body](values)
        )
        if getattr(inputs, 'error_columns', None) is not None:  # a speed drive's torque errors
            scales, biases = inputs.effects[body].loop_errors(k)
            helds[body, inputs.error_columns] = [x for pair in zip(scales, biases) for x in pair]

    def _kept(self, override) -> np.ndarray:
        # first read on the window's first interval: the previous is the one before it
        return self.kept.setdefault(override, self.previous)


_NO_SPEEDS = np.empty(0)


class _WheelSpeeds:
    """
    Each body's wheel speeds from its rows: ``Omega_i = h_i / Js_i - g_i . w``.

    A held array (``mode: hold``) has no state: its wheels' speeds are their scene speeds.
    """

    def __init__(self, index, spin_inertias, axes, held=None):
        self.index, self.spin_inertias, self.axes = index, spin_inertias, axes
        self.held = held  # (N, n): the held wheels' speeds, NaN for the others; None: none held

    @classmethod
    def of(cls, propagators) -> '_WheelSpeeds':
        index, spin, axes, held = [], [], [], []
        for body, propagator in enumerate(propagators):
            dynamics = propagator.dynamics
            wheels = [
                (e, p)
                for e, p in zip(dynamics.effects, dynamics.slices)
                if isinstance(e, ReactionWheels)
            ]
            if body == 0:  # (a held wheel's column is any: its speed replaces what it reads)
                index = [
                    7 + p.start + 2 * i if e.state_size else 0
                    for e, p in wheels
                    for i in range(e.count)
                ]
            spin.append(np.concatenate([e.spin_inertias for e, _ in wheels] or [np.empty(0)]))
            axes.append(np.concatenate([e.axes for e, _ in wheels] or [np.empty((0, 3))]))
            held.append(
                [s if e.holds_speeds() else math.nan for e, _ in wheels for s in e.speeds]
            )
        held = np.array(held, dtype=float)
        return cls(
            np.array(index, dtype=np.int64),
            np.array(spin),
            np.array(axes),
            held if held.size and not np.isnan(held).all() else None,
        )

    def __call__(self, rows: np.ndarray) -> np.ndarray:
        """Return the speeds of ``rows`` (``(N, n)``, or ``(N, M, n)`` with a samples axis)."""
        if not self.index.size:  # (no wheels: an empty array, not a computation)
            return _NO_SPEEDS.reshape(rows.shape[:-1] + (0,))
        if rows.ndim == 2:
            speeds = rows[:, self.index] / self.spin_inertias - np.einsum(
                'bij,bj->bi', self.axes, rows[:, :3]
            )
        else:
            speeds = rows[..., self.index] / self.spin_inertias[:, None, :] - np.einsum(
                'bij,bmj->bmi', self.axes, rows[..., :3]
            )
        if self.held is None:
            return speeds
        held = self.held if rows.ndim == 2 else self.held[:, None, :]
        return np.where(np.isnan(held), speeds, held)


def _as_scene(scene, where: str) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, Path)):
        return load_scene(scene)
    text = (
        f"{where}: expected a Scene, a scene file's path or a library scene's name, got {scene!r}"
    )
    raise ValueError(text[:300])


def _layout(propagator) -> tuple:
    """
    Return what a batch's bodies must share.

    Their motion effects' kinds, in order, and their frames.
    """
    return tuple(
        f'{e.name}{"(inertial)" if getattr(e, "inertial", False) else ""}'
        + (f'({e.count} wheels, mode {e.mode})' if isinstance(e, ReactionWheels) else '')
        for e in propagator.effects
    )
