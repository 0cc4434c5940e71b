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
The compiled path of the numerical propagators.

A scene's motion as a kernel model, and the drivers that run :mod:`.motion_kernels`' DOP853 and
fixed-step methods with the same stops (breakpoints, sample times), restarts and step budget as the
reference path in ``propagators/numerical.py``.

A propagator built while :data:`~torquefree_ros.core.numerics.kernels.ENABLED` holds evaluates
here; ``TORQUEFREE_ROS_KERNELS=numpy`` in the environment (or numba missing) keeps the reference
path, scipy's DOP853 and numpy's stages.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as tableau

from . import motion_kernels as kernels
from ..environment import place as environment
from ..numerics.steps import StepBudgetExceeded, StepTooSmall


# scipy's DOP853 tableau, as the kernels read it (contiguous float64 arrays)
_A = np.ascontiguousarray(tableau.A, dtype=float)
_B = np.ascontiguousarray(tableau.B, dtype=float)
_C = np.ascontiguousarray(tableau.C, dtype=float)
_E3 = np.ascontiguousarray(tableau.E3, dtype=float)
_E5 = np.ascontiguousarray(tableau.E5, dtype=float)
_D = np.ascontiguousarray(tableau.D, dtype=float)


def build_model(dynamics) -> np.ndarray:
    """
    Return the kernels' description of ``dynamics`` (layout in :mod:`.motion_kernels`).

    The inertia tensor integrated with (``dynamics.tensor``: the body's less the effects' spin
    inertia), its inverse, then one entry per effect with a kernel of its own (code, state offset,
    parameters), or several (a reaction wheel each: its parameters a whole number of its code's
    count, its state split evenly among them). Effects that hold a piecewise-constant torque have
    no entry (see :func:`held_torques`). An effect with a slot in ``held`` (:func:`held_slots`)
    has its slot's index in ``held`` where the others have their state's offset; a speed-mode
    wheel's entry has its state's offset, and the index of its pair (scale, bias) in its
    effect's slot as its last parameter (``motion_kernels.REACTION_WHEEL``).
    """
    entries, count = [], 0
    slots = held_slots(dynamics)
    for effect, part, slot in zip(dynamics.effects, dynamics.slices, slots):
        if effect.kernel_code is None:
            continue
        parameters = [float(v) for v in effect.kernel_parameters()]
        per_entry = kernels.PARAMETER_COUNTS[effect.kernel_code]
        several = len(parameters) // per_entry
        if several < 1 or several * per_entry != len(parameters) or effect.state_size % several:
            raise AssertionError(
                f'{effect.name}: {len(parameters)} kernel parameters and {effect.state_size} '
                f'states, its kernel reads {per_entry} per entry'
            )
        states = effect.state_size // several
        wheels = effect.kernel_code == kernels.REACTION_WHEEL
        for k in range(several):
            entry = parameters[k * per_entry: (k + 1) * per_entry]
            if wheels and slot is not None:  # its torque error's pair in the effect's slot
                entry[-1] = float(slot + 2 * k)
            entries += [
                float(effect.kernel_code),
                float(part.start + k * states if slot is None or wheels else slot),
                *entry,
            ]
        count += several
    tensor = dynamics.tensor
    header = [*tensor.ravel().tolist(), *np.linalg.inv(tensor).ravel().tolist(), float(count)]
    return np.array(header + entries, dtype=float)


#: the environment section's length (motion_kernels' ENV_* layout: the window, then each quantity's
#: Chebyshev coefficients per axis)
ENVIRONMENT_WIDTH = (
    kernels.ENV_COEFFICIENTS + 3 * environment.NODES * len(environment.QUANTITIES)
)


#: the environment windows a call of the kernels lays out at most beyond the times it reaches
STRETCH = 4 * environment.GROUP


def slot_size(effect) -> int:
    """
    Return how many inputs ``effect`` holds in a slot of its own in ``held`` (0: none).

    An effect without a state whose kernel reads inputs held per piece (magnetorquers' applied
    dipole) says so by ``held_slot_size`` and gives them by ``held_slot(segment_start)``.
    """
    return effect.held_slot_size


def held_slots(dynamics) -> list:
    """
    Return each effect's slot: its index in ``held``, or None (no slot).

    The slots follow the held inputs and the environment section, effect after effect.
    """
    at = kernels.HELD_TORQUES + dynamics.state_size
    at += ENVIRONMENT_WIDTH if dynamics.place is not None else 0
    slots = []
    for effect in dynamics.effects:
        size = slot_size(effect)
        slots.append(at if size else None)
        at += size
    return slots


def held_width(dynamics) -> int:
    """
    Return the length of the kernels' ``held``.

    The held torques, then an input per state, then the environment section when an effect reads
    the environment, then the effects' slots.
    """
    width = kernels.HELD_TORQUES + dynamics.state_size
    width += ENVIRONMENT_WIDTH if dynamics.place is not None else 0
    return width + sum(slot_size(effect) for effect in dynamics.effects)


def environment_section(dynamics, segment_start: float, out: np.ndarray) -> None:
    """
    Write the environment the piece from ``segment_start`` holds into ``out`` (its section).

    The window's start and scale, the count of coefficients, then the Chebyshev coefficients of
    each quantity the effects read (``environment_quantities``), axis by axis; zero elsewhere.
    """
    j = environment.window_of(segment_start)
    nodes = environment.NODES
    out = out[:ENVIRONMENT_WIDTH]
    out[:] = 0.0
    out[kernels.ENV_START] = j * environment.WINDOW
    out[kernels.ENV_SCALE] = 2.0 / environment.WINDOW
    out[kernels.ENV_NODES] = nodes
    quantities = {q for effect in dynamics.effects for q in effect.environment_quantities}
    for quantity in sorted(quantities):
        at = kernels.ENV_COEFFICIENTS + 3 * nodes * quantity
        out[at: at + 3 * nodes] = dynamics.place.chebyshev(j, quantity).ravel()


def held_torques(
    dynamics, segment_start: float, out: np.ndarray, commanded: bool | None = None
) -> np.ndarray:
    """
    Sum the torques held on the piece starting at ``segment_start`` into ``out``.

    ``out[:3]``: the sum of the body-frame torques, ``out[3:6]`` the inertial-frame ones (in the
    effects' order, as Dynamics adds them); then the inputs effects with a kernel hold on the
    piece (``held_inputs``, a wheel's motor torque) at their states' offsets, zero elsewhere, and
    in their slots (``held_slot``: magnetorquers' dipole). ``commanded``: only the effects that
    take commands (True), only the others (False), all (None). ``out`` may hold the torques alone
    (6 floats: the plant's commands). The environment section, when the scene has one, is the
    piece's (never commanded).
    """
    out[:] = 0.0
    whole = out.size == held_width(dynamics)
    if commanded is not True and dynamics.place is not None and whole:
        environment_section(
            dynamics, segment_start, out[kernels.HELD_TORQUES + dynamics.state_size:]
        )
    slots = held_slots(dynamics)
    for effect, part, slot in zip(dynamics.effects, dynamics.slices, slots):
        if commanded is not None and commanded != effect.takes_commands:
            continue
        if slot is not None:
            if whole:
                out[slot: slot + slot_size(effect)] = effect.held_slot(segment_start)
            if not effect.state_size:  # (a speed-mode wheel has its inputs too)
                continue
        if effect.kernel_code is None:
            torque, inertial = effect.held_torque(segment_start)
            if inertial:
                out[3:6] += torque
            else:
                out[:3] += torque
        elif out.size > kernels.HELD_TORQUES:
            inputs = effect.held_inputs(segment_start)
            if inputs is not None:
                start = kernels.HELD_TORQUES + part.start
                out[start: start + effect.state_size] = inputs
    return out


def derivatives(dynamics, times, states) -> np.ndarray:
    """
    Return ``y'`` of ``dynamics`` at each of ``states (N, 7 + state_size)`` at ``times``.

    Each time is its own piece start. Computed through the kernels: what the tests hold against
    ``Dynamics.derivative``.
    """
    kernels.compile_kernels()
    times = np.ascontiguousarray(times, dtype=float)
    states = np.ascontiguousarray(states, dtype=float)
    out = np.empty_like(states)
    model = build_model(dynamics)
    held = np.zeros(held_width(dynamics))
    for i in range(times.size):  # the held torques may change with the piece start
        held_torques(dynamics, float(times[i]), held)
        kernels.derivatives(times[i: i + 1], states[i: i + 1], model, held, out[i: i + 1])
    return out


class _Kernel:
    """State of one compiled run: the model, the flat state, scratch arrays the kernels reuse."""

    def __init__(self, propagator, work_rows: int):
        kernels.compile_kernels()
        self.propagator = propagator
        self.dynamics = propagator.dynamics
        self.size = 7 + self.dynamics.state_size
        self.model = build_model(self.dynamics)
        self.held = np.zeros(held_width(self.dynamics))
        self.y = np.empty(self.size)
        self.work = np.empty((work_rows, self.size))
        self.initial = np.concatenate([propagator.omega0_B, propagator.q0_NB, propagator.x0])

    def hold_from(self, t: float) -> None:
        held_torques(self.dynamics, t, self.held)


class DOP853Bodies:
    """
    Bodies stepped by DOP853 through the compiled kernels, all of them in one numba call.

    The plant's engine (``torquefree_ros.Plant``), and with one body the ``dop853`` propagator's
    (:class:`DOP853Kernel`), so the node's closed loop, its offline replay and ``Plant.step`` run
    the very same code. Each body's scene is cut into pieces at its breakpoints, each piece
    holding the torques the scene's own effects hold on it; with a ``sample_rate`` a new piece
    also begins at every sample time, holding the commanded torque given to :meth:`advance` on top.
    A body on an orbit also ends a piece at every environment window's end, each piece holding its
    window's environment; those pieces are laid out a stretch at a time, as the times asked for
    reach them (:data:`~..environment.place.GROUP` windows ahead at least).
    Steps are scipy's, a new piece selecting its initial step again (as a new scipy solver does).
    """

    def __init__(self, propagators, max_steps: int):
        kernels.compile_kernels()
        count, n = len(propagators), 7 + propagators[0].dynamics.state_size
        self.propagators = propagators
        self.width = n
        self.max_steps = int(max_steps)
        self.models = np.stack([build_model(p.dynamics) for p in propagators])
        self._schedules = [list(p.dynamics.breakpoints) for p in propagators]
        self._windowed = any(p.dynamics.place is not None for p in propagators)
        self._covered = None  # the windows (first, end) the pieces are laid out over
        width = held_width(propagators[0].dynamics)
        if not self._windowed:  # (else laid out as times reach them)
            self._lay_out_pieces()
        self.helds = np.zeros((count, width))
        self.rtols = np.array([p.rtol for p in propagators])
        self.atols = np.array([p.atol for p in propagators])
        self.min_steps = np.array([p.min_step for p in propagators])
        self.initial = np.stack([np.concatenate([p.omega0_B, p.q0_NB, p.x0]) for p in propagators])
        self.solvers = np.zeros((count, kernels.SOLVER_WIDTH))
        self.ys = self.initial.copy()
        self.y_olds = np.empty((count, n))
        self.fs = np.empty((count, n))
        self.Ks = np.empty((count, kernels.STAGES_EXTENDED, n))
        self.Fs = np.empty((count, kernels.INTERPOLATOR_POWER, n))
        self.works = np.empty((count, 3, n))
        self.status = np.zeros(count, dtype=np.int64)  # each body's last kernels status
        self.reached = np.zeros(count, dtype=np.int64)  # the output index it stopped at

    @property
    def size(self) -> int:
        return self.ys.shape[0]

    def restart(self) -> None:
        """Every body back to its initial state: a piece that ended at t = 0."""
        self.ys[:] = self.initial
        self.solvers[:] = 0.0

    def _lay_out_pieces(self, first: int = 0, end: int = 0) -> None:
        """
        Lay out each body's pieces: :attr:`breaks` and what each piece holds, :attr:`piece_helds`.

        ``breaks[b]``: where body ``b``'s pieces end, ascending, padded with inf; ``piece_helds[b,
        j]``: what piece ``j`` holds from its start (the one before ``breaks[b, 0]`` first). A body
        without an orbit gets its whole schedule. A body on an orbit gets the pieces of windows
        ``first`` to ``end - 1``: its schedule's breakpoints there and every window end; the piece
        after the last end is never begun (times past it lay out the next stretch first), and
        holds NaN.
        """
        window = environment.WINDOW
        low, high = first * window, end * window
        breaks, begins = [], []
        for p, schedule in zip(self.propagators, self._schedules):
            if p.dynamics.place is None:
                breaks.append(schedule)
                begins.append(0.0)
                continue
            ends = {k * window for k in range(first + 1, end + 1)}
            breaks.append(sorted(ends.union(s for s in schedule if low < s < high)))
            begins.append(low)
        pieces = max(1, max(len(b) for b in breaks))
        self.breaks = np.array([b + [np.inf] * (pieces - len(b)) for b in breaks])
        width = held_width(self.propagators[0].dynamics)
        self.piece_helds = np.zeros((len(self.propagators), pieces + 1, width))
        for body, (p, ends, begin) in enumerate(zip(self.propagators, breaks, begins)):
            for piece, start in enumerate([begin, *ends]):
                row = self.piece_helds[body, piece]
                if p.dynamics.place is not None and piece == len(ends):
                    row[:] = np.nan
                else:
                    held_torques(p.dynamics, start, row, commanded=False)

    def _cover(self, t_from: float, t_to: float) -> None:
        """Lay out the pieces of the windows from ``t_from`` to ``t_to``, unless laid out."""
        first = environment.window_of(t_from)
        end = environment.window_of(t_to) + 1
        covered = self._covered
        if covered is not None and covered[0] <= first and end <= covered[1]:
            return
        try:
            ahead = max(end, first + environment.GROUP)
            self._lay_out_pieces(first, ahead)
        except ValueError:  # the stretch ahead passes the field model's years: only what is asked
            ahead = end
            self._lay_out_pieces(first, end)  # (which raises if the times themselves pass them)
        self._covered = (first, ahead)

    def advance(
        self, times: np.ndarray, command_helds: np.ndarray, sample_rate: float = 0.0
    ) -> np.ndarray:
        """
        Return every body's state at ``times`` (ascending), an ``(N, M, n)`` array.

        ``command_helds (N, 6)``: the commanded torque (body frame, inertial frame) held on the
        pieces begun in this call; wider, the commanded inputs after them (as :func:`held_torques`
        lays them out). Afterwards :attr:`status` says, body by body, DONE or why the
        body stopped (:func:`dop853_error` words it), at output :attr:`reached`.
        """
        if self._windowed and times.size:
            return self._advance_windowed(times, command_helds, sample_rate)
        return self._run(times, command_helds, sample_rate)

    def _advance_windowed(
        self, times: np.ndarray, command_helds: np.ndarray, sample_rate: float
    ) -> np.ndarray:
        """
        :meth:`advance` for bodies on an orbit: a stretch of :data:`STRETCH` windows at a time.

        Each call of the kernels has its pieces laid out first, and lays out no more than a
        stretch beyond the times it reaches: a stretch without a time asked for is crossed with a
        stop of its own at its end, whose state is dropped (outputs never shape the steps, so
        the samples are those of one call).
        """
        out = np.empty((self.size, times.size, self.width))
        i = 0
        reached = float(self.solvers[:, kernels.T].min())
        while i < times.size:
            stop = (environment.window_of(reached) + STRETCH) * environment.WINDOW
            j = i + int(np.searchsorted(times[i:], stop, side='right'))
            part = times[i:j] if j > i else np.array([stop])
            self._cover(reached, float(part[-1]))
            rows = self._run(part, command_helds, sample_rate)
            if np.any(self.status != kernels.DONE):
                if j > i:
                    self.reached += i
                else:  # (on the way to a stop of its own: the next time asked was not reached)
                    self.reached[:] = i
                return out
            out[:, i:j] = rows[:, : j - i]
            i = j
            reached = float(self.solvers[:, kernels.T].min())
        return out

    def _run(self, times: np.ndarray, command_helds: np.ndarray, sample_rate: float) -> np.ndarray:
        """Run the kernels over ``times`` for every body (the pieces laid out)."""
        out = np.empty((self.size, times.size, self.width))
        kernels.dop853_outputs_batch(
            times,
            out,
            self.max_steps,
            sample_rate,
            self.breaks,
            self.piece_helds,
            command_helds,
            self.solvers,
            self.ys,
            self.y_olds,
            self.fs,
            self.Ks,
            self.Fs,
            self.works,
            self.models,
            self.helds,
            self.rtols,
            self.atols,
            self.min_steps,
            _A,
            _B,
            _C,
            _E3,
            _E5,
            _D,
            self.status,
            self.reached,
        )
        return out


class DOP853Kernel:
    """
    ``DOP853Propagator``'s evaluation through the kernels: a :class:`DOP853Bodies` of one body.

    Free steps (outputs never shape them), a new piece at each breakpoint (initial step selected
    again, as a new scipy solver does). A scene whose torque is held from sample to sample (a
    controller's commands) advances one sample interval a call, holding the command in force on
    it, as ``Plant.step`` does.
    """

    def __init__(self, propagator):
        self.propagator = propagator
        self.dynamics = propagator.dynamics
        self.bodies = DOP853Bodies([propagator], -1)
        self.command_helds = np.zeros((1, held_width(self.dynamics)))
        self._command_held = self.command_helds[0]

    def restart(self) -> None:
        """Go back to the initial state; the first step begins a new piece."""
        self.bodies.restart()

    def evaluate(self, times: np.ndarray) -> np.ndarray:
        bodies, dynamics = self.bodies, self.dynamics
        budget = self.propagator.max_steps_per_sample
        bodies.max_steps = -1 if budget is None else int(budget)
        rate = dynamics.sample_rate or 0.0
        out = np.empty((times.size, bodies.width))
        i = 0
        while i < times.size:
            reached = float(bodies.solvers[0, kernels.T])
            if rate:  # up to the end of the sample interval the body is in, the command in force
                end = kernels.next_sample_time(reached, rate)
                if times[-1] <= end:  # (a closed loop's one sample at a time)
                    j = times.size
                else:
                    j = i + int(np.searchsorted(times[i:], end, side='right'))
                part = times[i:j] if j > i else np.array([end])  # (none asked: to its end)
                held_torques(dynamics, reached, self._command_held, commanded=True)
            else:
                j, part = times.size, times[i:]
            rows = bodies.advance(part, self.command_helds, rate)[0]
            status = int(bodies.status[0])
            if status == kernels.RESTART:  # a time before the last step: from the start again
                self.restart()
                continue
            if status != kernels.DONE:
                at = float(part[min(int(bodies.reached[0]), part.size - 1)])
                raise dop853_error(status, self.propagator, at, bodies.solvers[0])
            if j > i:
                out[i:j] = rows
                i = j
        return out


def dop853_error(status: int, propagator, t: float, solver: np.ndarray) -> RuntimeError:
    """
    Return the error for a DOP853 kernel's ``status`` on the way to ``t``.

    ``status`` is BUDGET, TOO_SMALL or STIFF; the error is in the reference path's words.
    """
    step = abs(float(solver[kernels.H_PREVIOUS])) or float(solver[kernels.H_ABS])
    at = float(solver[kernels.T])
    if status == kernels.BUDGET:
        return StepBudgetExceeded(propagator, t, step)
    if status == kernels.TOO_SMALL:
        return StepTooSmall(propagator, at)
    return RuntimeError(
        f'dop853: the step fell to {step:.2g} s at t = {at:.6g} s, '
        f'under {propagator.min_step:.2g} s (1e-7 of a turn): '
        "the scene's effects are too stiff for an explicit integrator"
    )


class FixedStepKernel(_Kernel):
    """
    A fixed-step propagator's steps through the kernels.

    Whole grid steps in one call up to the next breakpoint, a step holding a breakpoint split there
    (numerical.py's ``_advance``).
    """

    def __init__(self, propagator, method: int):
        super().__init__(propagator, 9)
        self.method = method
        self.partial = np.empty(self.size)
        self.grid = np.zeros(1)  # the grid index the kernel's loop reached

    def restart(self) -> None:
        self.y[:] = self.initial
        self.grid[0] = 0.0

    @property
    def whole_loop(self) -> bool:
        """
        Tell whether there is no breakpoint anywhere.

        No schedule, no torque held per sample, no environment window. Then the loop over the
        times runs in the kernel, with the held torques of t = 0 throughout.
        """
        return (
            not self.dynamics.breakpoints
            and self.dynamics.sample_rate is None
            and self.dynamics.place is None
        )

    def evaluate(self, times: np.ndarray) -> np.ndarray:
        """Every sample at ``times`` (for :attr:`whole_loop` scenes)."""
        out = np.empty((times.size, self.size))
        budget = self.propagator.max_steps_per_sample
        budget = -1 if budget is None else int(budget)
        self.hold_from(0.0)
        i = 0
        while i < times.size:
            i, status = kernels.fixed_outputs(
                self.method,
                times,
                i,
                out,
                budget,
                self.propagator.step,
                self.grid,
                self.y,
                self.partial,
                self.model,
                self.held,
                self.work,
            )
            if status == kernels.RESTART:
                self.propagator._restart()
            elif status == kernels.BUDGET:
                raise StepBudgetExceeded(self.propagator, float(times[i]), self.propagator.step)
        self.propagator._grid_index = int(self.grid[0])
        return out

    def advance_grid(self, j: int, j_end: int, step: float) -> None:
        """From grid point ``j`` to ``j_end``, in place."""
        next_breakpoint = self.dynamics.next_breakpoint
        while j < j_end:
            t = j * step
            bound = next_breakpoint(t)
            self.hold_from(t)
            reached = kernels.fixed_steps(
                self.method, j, j_end, step, bound, self.y, self.model, self.held, self.work
            )
            if reached == j:  # a breakpoint inside step j
                self._advance(t, self.y, step)
                reached += 1
            j = reached

    def partial_step(self, t: float, h: float) -> np.ndarray:
        """Return the state ``h`` after grid time ``t`` (the grid state untouched)."""
        self.partial[:] = self.y
        self._advance(t, self.partial, h)
        return self.partial

    def _advance(self, t: float, y: np.ndarray, h: float) -> None:
        end = t + h
        next_breakpoint = self.dynamics.next_breakpoint
        stop = next_breakpoint(t)
        while stop < end:
            self.hold_from(t)
            kernels.fixed_step(self.method, t, y, stop - t, self.model, self.held, self.work)
            t, stop = stop, next_breakpoint(stop)
        self.hold_from(t)
        kernels.fixed_step(self.method, t, y, end - t, self.model, self.held, self.work)
