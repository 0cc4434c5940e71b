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
then the torque is zero) and returns the state at ``k + 1``. ``Plant([scene, ...], rate)`` holds N
bodies, each with its own inertia, initial state and effect parameters; ``step`` takes ``(N, 3)``
torques and one compiled call advances every body. A body of a batch is bit for bit the same body
alone: both run the same kernel (``motion_kernels.dop853_outputs_batch``) with the same numbers.

The plant integrates with DOP853 at the scene's ``accuracy`` (``auto``'s settings) through
``drivers.DOP853Bodies``, the engine the ``dop853`` propagator runs with one body: the node's
closed loop and its offline replay run the same object (the stepping starts again at every sample
when the scene takes commands, and at every switch of a torque schedule, each body of a batch at
its own).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..core.commands.hold import timed_out, torque_refusals
from ..core.compiled import drivers
from ..core.compiled import motion_kernels as kernels
from ..core.effects.commands import command_inputs
from ..core.propagators import ATOL_PER_RTOL, DEFAULT_ACCURACY, MAX_STEPS_PER_SAMPLE
from ..core.scene.loader import load_scene, Scene
from ..core.timing.grid import check_rate, sample_stamp_ns


class PlantState(NamedTuple):
    """
    A sample: body rates, attitude and the effects' own states.

    Body rates (rad/s, body frame), attitude ``q_NB`` (x, y, z, w) and the effects' own states (a
    damper's rate); a batch has a leading axis of bodies.
    """

    omega_B: np.ndarray
    q_NB: np.ndarray
    internal: np.ndarray


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

    # -- stepping --------------------------------------------------------------------------------
    def step(self, torque=None) -> PlantState:
        """
        Hold ``torque`` over ``[t_k, t_k+1)`` and return the state at ``k + 1``.

        ``torque``: N m, in the ``torque_command`` effect's frame; ``(3,)``, or ``(N, 3)`` for a
        batch. ``None``: no new command (the one in force holds until its timeout). A refused
        torque raises ``ValueError`` and changes nothing.
        """
        if torque is not None:
            self._accept(torque)
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
        if self._commands is not None:
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
        self._command_helds = np.zeros((count, 6))
        self._sample = self._bodies.ys.copy()[:, None, :]
        self.k = 0
        self._failed: str | None = None
        commands = [command_inputs(p.effects) for p in propagators]
        if any(len(c) > 1 for c in commands):
            raise ValueError(
                'scene: more than one torque_command effect; the plant takes one torque per body'
            )
        if commands[0]:
            effects = [c[0] for c in commands]
            self._commands = _Commands(
                inertial=effects[0].inertial,
                timeout_ns=np.array([e.hold.timeout_ns for e in effects], dtype=np.int64),
                max_torque=np.array([e.hold.max_torque for e in effects]),
                torque=np.zeros((count, 3)),
                stamp_ns=np.full(count, np.iinfo(np.int64).min // 2, dtype=np.int64),
            )
        else:
            self._commands = None

    def _accept(self, torque) -> None:
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
        commands.torque[:] = values
        commands.stamp_ns[:] = sample_stamp_ns(self.k, self.rate)

    def _hold(self) -> None:
        """
        Set the commanded torque over ``[t_k, t_k+1)`` for every body.

        The command in force (zero once it timed out), in its frame, added to the scene's constant
        torques (CommandHold's rule, for every body at once).
        """
        commands = self._commands
        if commands is None:
            return
        in_force = ~timed_out(
            sample_stamp_ns(self.k, self.rate), commands.stamp_ns, commands.timeout_ns
        )
        held = np.where(in_force[:, None], commands.torque, 0.0)
        self._command_helds[:] = 0.0
        if commands.inertial:
            self._command_helds[:, 3:] = held
        else:
            self._command_helds[:, :3] = held

    def _advance(self, times: np.ndarray) -> np.ndarray:
        if self._failed is not None:
            raise RuntimeError(
                f'plant: stopped at sample {self.k} ({self._failed}); reset() starts it again'
            )
        self._hold()
        sample_rate = self.rate if self._commands is not None else 0.0
        out = self._bodies.advance(times, self._command_helds, sample_rate)
        failed = np.flatnonzero(self._bodies.status != kernels.DONE)
        if failed.size:
            self._fail(int(failed[0]), times)
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
        if not self.batch:
            rows = rows[0]
        return PlantState(rows[..., :3].copy(), rows[..., 3:7].copy(), rows[..., 7:].copy())


class _Commands(NamedTuple):
    inertial: bool
    timeout_ns: np.ndarray
    max_torque: np.ndarray
    torque: np.ndarray  # the last accepted command per body
    stamp_ns: np.ndarray  # the stamp of the sample it was given at


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
        for e in propagator.effects
    )
