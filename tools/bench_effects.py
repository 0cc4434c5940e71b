#!/usr/bin/env python3
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
Benchmark of the numerical propagators on scenes with motion effects (issue 27).

A script, not a test: it prints what it measured and the machine.

Per case (a scene with a motion effect, DOP853 at the scene's accuracy: rtol = accuracy, atol =
accuracy / 100, what ``auto`` builds), the CPU time (``time.process_time``) per simulated second of
a 100 Hz output, side by side in one process:

- **compiled**: the default path (numba kernels, ``core/integrators``);
- **reference**: the same propagator with ``kernels.ENABLED = False`` (scipy's DOP853, Python
  right-hand side; what ``TORQUEFREE_ROS_KERNELS=numpy`` selects);
- **cyrk**: the ``cyrk`` library's C++ DOP853 (``nbsolve2_ivp``, its numba entry point) on a numba
  ``cfunc`` right-hand side that calls ``motion_kernels.derivative`` (the compiled path's own), at
  the same rtol/atol with ``t_eval`` the same sample times; a torque schedule is integrated piece
  by piece between its breakpoints (the held torque set for each piece), as the propagators do.

A run is what a user pays from a loaded scene: the propagator built (for cyrk: built on the
reference path, for its Dynamics, plus the kernels' model) and every sample computed. Beside each
figure, the largest attitude error (rad) and angular-velocity error against a tight reference: the
reference path at rtol 1e-13, atol 1e-15. The ratios compiled / reference and compiled / cyrk are
taken within each round, on the same case, one run right after the other.

Where the compiled path's time goes: building, stepping, outputs, per step and per right-hand-side
call beside cyrk's (both take scipy's steps and call the right-hand side as often: counted). Then
the floor of a DOP853 step: the operations it must run one after the other (``_critical_path``), at
this machine's latencies measured here, against a quarter of cyrk's step (issue 27's target).

Then what numba costs a process: a new process (``sys.executable -c``) that imports the package,
builds explorer1's propagator and evaluates one sample, with the kernels loaded from numba's cache,
with ``TORQUEFREE_ROS_KERNELS=numpy``, and with an empty cache (``NUMBA_CACHE_DIR`` a new
directory: the first use, compiling): wall time from outside (interpreter start and the ROS wheels'
re-exec included, the same in all), time inside the child, and its peak RSS (``VmHWM``;
``ru_maxrss`` beside it, which a forked child inherits from this process).

Each timing is the fastest of ``--calls`` runs (the least disturbed on a shared machine); a round
measures everything once, and ``--rounds`` rounds give median (min–max).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
import importlib.metadata
import importlib.util
import json
import math
import os
from pathlib import Path
import platform
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import fastest as fastest_of  # noqa: E402
from bench_report import Report, spread  # noqa: E402
from torquefree_ros.core.numerics import kernels as switch  # noqa: E402

RATE = 100.0  # Hz
TIGHT_RTOL, TIGHT_ATOL = 1e-13, 1e-15
TARGET_REFERENCE, TARGET_CYRK, TARGET_EXPLORER1_US = 0.02, 0.25, 40.0
PATHS = ('compiled', 'reference', 'cyrk')

CONSTANT_TORQUE_SCENE = {
    'description': 'a triaxial body under a constant torque fixed in the inertial frame',
    'body': {'inertia': [2.0, 3.0, 4.0]},
    'initial': {'angular_velocity': [0.3, 0.2, 1.0], 'orientation': [0.0, 0.0, 0.0, 1.0]},
    'effects': [{'external_torque': {'torque': [0.02, -0.01, 0.03], 'frame': 'inertial'}}],
}
SCHEDULE_SCENE = {
    'description': 'the same body under an inertial torque schedule of five segments',
    'body': {'inertia': [2.0, 3.0, 4.0]},
    'initial': {'angular_velocity': [0.3, 0.2, 1.0], 'orientation': [0.0, 0.0, 0.0, 1.0]},
    'effects': [
        {
            'external_torque': {
                'frame': 'inertial',
                'schedule': [
                    {'start': 0.0, 'torque': [0.02, -0.01, 0.03]},
                    {'start': 20.0, 'torque': [0.0, 0.05, 0.0]},
                    {'start': 40.0, 'torque': [-0.03, 0.0, 0.01]},
                    {'start': 60.0, 'torque': [0.0, 0.0, 0.0]},
                    {'start': 80.0, 'torque': [0.01, 0.02, -0.04]},
                ],
            }
        }
    ],
}


@dataclass
class Case:
    name: str
    effect: str
    scene: object
    duration: float  # s
    rtol: float
    atol: float
    times: object = None
    reference: tuple = None  # (w, q) of the tight reference
    # the compiled path at the tight tolerances vs the reference
    floor: dict = field(default_factory=dict)

    def propagator(self):
        # DOP853, auto's integrator for an effects scene (for the library gyrostat's rotor, along a
        # principal axis, auto takes the exact gyrostat: its cost is measured beside it, issue 43)
        return self.scene.propagator('dop853', rtol=self.rtol, atol=self.atol)


def _cases() -> list[Case]:
    import numpy as np
    from torquefree_ros import load_scene
    from torquefree_ros.core.propagators import ATOL_PER_RTOL, DEFAULT_ACCURACY
    from torquefree_ros.core.scene.loader import scene_from_mapping

    def case(name, effect, scene, duration, rtol=None):
        rtol = rtol if rtol is not None else (scene.accuracy or DEFAULT_ACCURACY)
        c = Case(name, effect, scene, duration, rtol, rtol * ATOL_PER_RTOL)
        c.times = np.arange(int(round(duration * RATE)) + 1) / RATE
        return c

    explorer1 = load_scene('explorer1')
    return [
        case('explorer1', 'damper', explorer1, 100.0),
        case('explorer1 @ 1e-10', 'damper', explorer1, 100.0, rtol=1e-10),
        case('gyrostat', 'rotor', load_scene('gyrostat'), 100.0),
        case('gravity_gradient', 'gravity_gradient', load_scene('gravity_gradient'), 3000.0),
        case(
            'inertial torque',
            'external_torque (constant, inertial)',
            scene_from_mapping(CONSTANT_TORQUE_SCENE, '<bench: constant inertial torque>'),
            100.0,
        ),
        case(
            'inertial schedule',
            'external_torque (5-segment schedule, inertial)',
            scene_from_mapping(SCHEDULE_SCENE, '<bench: inertial torque schedule>'),
            100.0,
        ),
    ]


# -- cyrk
# -----------------------------------------------------------------------------------------------

_CYRK = {}


def _cyrk_setup():
    """
    Build cyrk's cfunc right-hand side and an njit driver, once.

    The cfunc right-hand side has cyrk's diffeq signature, ``void(dy*, t, y*, args*)``. ``args`` =
    (n, model size, 3 unused floats (were scratch), held torques (6), model): they live in cyrk's
    own copy of ``args``, so the right-hand side allocates nothing.
    """
    if _CYRK:
        return _CYRK
    from CyRK import nbsolve2_ivp
    from CyRK.nb.numba_solver import cyjit_sig
    from numba import carray
    import numba as nb
    from torquefree_ros.core.compiled import motion_kernels

    motion_kernels.compile_kernels()
    derivative = motion_kernels.derivative

    @nb.cfunc(cyjit_sig, error_model='numpy')
    def diffeq(dy, t, y, args):
        head = carray(args, (2,))
        n, size = int(head[0]), int(head[1])
        a = carray(args, (11 + size,))
        derivative(t, carray(y, (n,)), a[11:], a[5:11], carray(dy, (n,)))

    @nb.njit
    def solve(address, t0, t1, y0, t_eval, args, rtol, atol, out):
        """One smooth piece; its samples into ``out`` (rows = t_eval), returns (status, steps)."""
        sol = nbsolve2_ivp(
            address, (t0, t1), y0, method='DOP853', t_eval=t_eval, args=args, rtol=rtol, atol=atol
        )
        status, steps = sol.status, sol.steps_taken
        if sol.success:
            y = sol.y
            for i in range(out.shape[0]):
                for k in range(out.shape[1]):
                    out[i, k] = y[k, i]
        sol.free()
        return status, steps

    _CYRK.update(address=diffeq.address, solve=solve)
    return _CYRK


def _cyrk_run(case: Case, times=None):
    """
    Return cyrk's (w, q, steps) at ``times``.

    ``times`` defaults to ``case.times``; a sample on every breakpoint. From the scene: its
    Dynamics (a propagator on the reference path, which builds no kernel state), the kernels'
    model, then cyrk piece by piece.
    """
    import numpy as np
    from torquefree_ros.core.compiled import drivers

    cy = _CYRK
    switch.ENABLED = False
    p = case.propagator()
    dynamics = p.dynamics
    model = drivers.build_model(dynamics)
    y = np.concatenate([p.omega0_B, p.q0_NB, p.x0])
    n = y.size
    args = np.empty(11 + model.size)
    args[0], args[1], args[2:5] = n, model.size, 0.0
    args[11:] = model
    times = case.times if times is None else times
    out = np.empty((times.size, n))
    t0, first, steps = 0.0, 0, 0
    while first < times.size:
        t1 = min(dynamics.next_breakpoint(t0), float(times[-1]))
        # a sample on the breakpoint ends this piece
        last = int(np.searchsorted(times, t1, side='right'))
        drivers.held_torques(dynamics, t0, args[5:11])
        status, taken = cy['solve'](
            cy['address'],
            t0,
            t1,
            y,
            times[first:last],
            args,
            case.rtol,
            case.atol,
            out[first:last],
        )
        if status < 0:
            raise RuntimeError(f'cyrk failed on {case.name} at t = {t0}: status {status}')
        steps += taken
        if last < times.size and times[last - 1] != t1:
            raise AssertionError(
                'a piece must end on a sample time for the next to start from its state'
            )
        y = out[last - 1].copy()
        t0, first = t1, last
    q = out[:, 3:7]
    return out[:, :3], q / np.linalg.norm(q, axis=1, keepdims=True), steps


# -- our paths
# ------------------------------------------------------------------------------------------


def _ours(case: Case, path: str):
    switch.ENABLED = path == 'compiled'
    p = case.propagator()
    if p.compiled != (path == 'compiled'):
        raise AssertionError(f'{case.name}: asked for the {path} path, got compiled={p.compiled}')
    w, q, _ = p.states(case.times)
    return w, q


def _run(case: Case, path: str):
    if path == 'cyrk':
        w, q, _ = _cyrk_run(case)
        return w, q
    return _ours(case, path)


def _errors(case: Case, w, q) -> tuple[float, float]:
    import numpy as np
    from torquefree_ros.core.frames import quaternion

    w_ref, q_ref = case.reference
    return (
        float(np.max(quaternion.angle_between(q_ref, q))),
        float(np.max(np.linalg.norm(w - w_ref, axis=1))),
    )


def _tight_references(cases: list[Case]) -> None:
    """
    Set each case's tight reference: the reference path at rtol 1e-13, atol 1e-15.

    And the compiled path there beside it, in ``case.floor`` (how far the error measure can see).
    """
    for case in cases:
        for path in ('reference', 'compiled'):
            switch.ENABLED = path == 'compiled'
            p = case.scene.propagator('dop853', rtol=TIGHT_RTOL, atol=TIGHT_ATOL)
            w, q, _ = p.states(case.times)
            if path == 'reference':
                case.reference = (w, q)
            else:
                case.floor = dict(zip(('attitude', 'omega'), _errors(case, w, q)))


def _round(cases: list[Case], calls: int) -> dict:
    """
    Run every case on every path, interleaved call by call.

    Returns {(case, path): (seconds, attitude error, w error)}.
    """
    result = {}
    for case in cases:
        best = {path: float('inf') for path in PATHS}
        errors = {}
        for _ in range(calls):
            for path in PATHS:
                started = time.process_time()
                w, q = _run(case, path)
                best[path] = min(best[path], time.process_time() - started)
                errors[path] = (w, q)
        for path in PATHS:
            result[case.name, path] = (best[path], *_errors(case, *errors[path]))
    return result


def _stops(case: Case):
    """
    Return the breakpoints before the end, and the end.

    A run's times with no output between them.
    """
    import numpy as np

    p = case.propagator()
    stops, t, end = [], 0.0, float(case.times[-1])
    while (t := p.dynamics.next_breakpoint(t)) < end:
        stops.append(t)
    return np.array(stops + [end])


def _diagnostics(cases: list[Case], calls: int) -> dict:
    """
    Measure where the compiled path's time goes, per case.

    Building the propagator, its kernel's evaluate (the stepping, the outputs and q normalised in
    them), the rest of states(); the kernel and cyrk stepping alone (outputs only at the
    breakpoints and the end), so that (all - stepping) / samples is the outputs' cost; scipy's
    DOP853 step count over the same run (solve_ivp on the compiled right-hand side, piece by piece:
    the compiled path takes scipy's steps) beside cyrk's.
    """
    from CyRK import pysolve_ivp
    import numpy as np
    from scipy.integrate import solve_ivp
    from torquefree_ros.core.compiled import drivers, motion_kernels

    def fastest(function):
        return fastest_of(function, calls, time.process_time)

    rows = {}
    for case in cases:
        switch.ENABLED = True
        build = evaluate = total = float('inf')
        for _ in range(calls):
            started = time.process_time()
            p = case.propagator()
            built = time.process_time()
            p.states(case.times)
            done = time.process_time()
            p._kernel.restart()
            again = time.process_time()
            p._kernel.evaluate(case.times)
            evaluated = time.process_time()
            evaluate = min(evaluate, evaluated - again)
            build, total = min(build, built - started), min(total, done - started)
        stops = _stops(case)

        def stepping():
            p._kernel.restart()
            p._kernel.evaluate(stops)

        kernel_stepping = fastest(stepping)
        cyrk_all = fastest(lambda: _cyrk_run(case))
        cyrk_stepping = fastest(lambda: _cyrk_run(case, stops))
        _, _, cyrk_steps = _cyrk_run(case)

        model = drivers.build_model(p.dynamics)
        held = np.zeros(6)

        def f(t, y):
            out = np.empty_like(y)
            motion_kernels.derivative(t, y, model, held, out)
            return out

        counter = [0]

        def counted(t, y):
            counter[0] += 1
            return f(t, y)

        steps = evaluations = cyrk_evaluations = 0
        t0, end = 0.0, float(case.times[-1])
        y = np.concatenate([p.omega0_B, p.q0_NB, p.x0])
        y_cyrk = y.copy()
        while t0 < end:
            t1 = min(p.dynamics.next_breakpoint(t0), end)
            drivers.held_torques(p.dynamics, t0, held)
            sol = solve_ivp(f, (t0, t1), y, method='DOP853', rtol=case.rtol, atol=case.atol)
            steps += sol.t.size - 1
            evaluations += sol.nfev
            # cyrk's right-hand-side calls: the same solver through its Python entry point, counted
            counter[0] = 0
            run = pysolve_ivp(
                counted, (t0, t1), y_cyrk, method='DOP853', rtol=case.rtol, atol=case.atol
            )
            cyrk_evaluations += counter[0]
            y, y_cyrk, t0 = sol.y[:, -1], np.ascontiguousarray(run.y[:, -1]), t1
        samples = case.times.size - stops.size
        rows[case.name] = {
            'build_us': build * 1e6,
            'evaluate_us': evaluate * 1e6,
            'rest_us': (total - build - evaluate) * 1e6,
            'steps': steps,
            'cyrk_steps': cyrk_steps,
            'evaluations': evaluations,
            'cyrk_evaluations': cyrk_evaluations,
            'kernel_step_us': kernel_stepping / steps * 1e6,
            'cyrk_step_us': cyrk_stepping / cyrk_steps * 1e6,
            'kernel_call_ns': kernel_stepping / evaluations * 1e9,
            'cyrk_call_ns': cyrk_stepping / cyrk_evaluations * 1e9,
            'kernel_output_ns': (evaluate - kernel_stepping) / samples * 1e9,
            'cyrk_output_ns': (cyrk_all - cyrk_stepping) / samples * 1e9,
        }
    switch.ENABLED = True
    return rows


# -- the floor of a step
# ----------------------------------------------------------------------------------


def _latencies(calls: int) -> dict:
    """
    Measure the ns of one operation in a chain of dependent ones, compiled.

    Each operation waits for the one before: double addition, multiplication, division, square
    root, and ``x ** -0.125`` (the C library's pow, scipy's step factor).
    """
    import numba

    @numba.njit
    def add(n, x):
        s = x
        for _ in range(n):
            s = s + x
        return s

    @numba.njit
    def mul(n, x):
        s = x
        for _ in range(n):
            s = s * x
        return s

    @numba.njit
    def div(n, x):
        s = x
        for _ in range(n):
            s = x / s
        return s

    @numba.njit
    def sqrt(n, x):
        s = x
        for _ in range(n):
            s = math.sqrt(s)
        return s

    @numba.njit
    def pow_(n, x):  # s stays near 1.06 (no denormals, no overflow): 1 + 0.06 s^-1/8
        s = x
        for _ in range(n):
            s = 1.0 + 0.06 * s**-0.125
        return s

    result = {}
    for name, function, count, x in (
        ('add', add, 20_000_000, 1.0000001),
        ('mul', mul, 20_000_000, 1.0000001),
        ('div', div, 5_000_000, 1.0000001),
        ('sqrt', sqrt, 5_000_000, 1.5),
        ('pow', pow_, 2_000_000, 1.06),
    ):
        function(10, x)  # compiled
        result[name] = (
            fastest_of(lambda: function(count, x), calls, time.perf_counter) / count * 1e9
        )
    # pow's chain also holds one multiplication and one addition
    result['pow'] -= result['mul'] + result['add']
    return result


def _critical_path(n: int) -> dict:
    """
    Count the operations one DOP853 step must run one after the other on explorer1's scene.

    The operations one DOP853 step must run one after the other on explorer1's scene (``n`` state
    components, a damper), however it is coded: each stage's state waits for the right-hand side of
    the stage before, the next step waits for the step factor. A stage's sum over the earlier
    stages can be added up while the newest one is computed; its newest term comes last in scipy's
    order of ``j`` (which the samples keep), so what waits is that term's product and one addition:

    - stages 2 to 11: the newest term (a multiplication, an addition), times ``h``, plus ``y``
      (stage 1: times ``h``, plus ``y``); then the right-hand side on that state: ``I w`` (a
      multiplication, two additions), ``(I w) x w`` (a multiplication, a subtraction), plus the
      held torque and the damper's (two additions), ``I^-1 m`` (a multiplication, two additions);
    - the new state: the solution's newest term (a multiplication, an addition), times ``h``, plus
      ``y`` (the last right-hand side is not on the path: the error does not read it); the error
      scale ``atol + max(|y|, |y_new|) rtol`` (a maximum, a multiplication, an addition);
    - the error: a division by the scale, a square, the sum of squares over the ``n`` components,
      ``err5 + 0.01 err3``, times ``n``, a square root, a division; the factor ``0.9 error^-1/8``
      (pow, a multiplication); ``h`` times it; the next step's ``t + h`` and ``h = t_new - t``.

    Everything else (the other terms, the loads and stores, the other components, the last
    right-hand side) is taken as free: a floor, not an estimate.
    """
    from scipy.integrate._ivp import dop853_coefficients as tableau

    # the newest stage's coefficient is not zero in any stage, nor in the solution's and error's
    # weights
    if not (
        all(tableau.A[s, s - 1] != 0 for s in range(2, 12))
        and tableau.B[11] != 0
        and tableau.E5[11] != 0
    ):
        raise AssertionError("scipy's DOP853 tableau changed: recount the critical path")
    rhs_mul, rhs_add = 3, 7
    muls = 1 + 10 * 2 + 11 * rhs_mul + 2 + 1 + 1 + 1 + 1 + 1
    adds = 1 + 10 * 2 + 11 * rhs_add + 2 + 2 + n + 1 + 2  # the maximum counted as an addition
    return {'add': adds, 'mul': muls, 'div': 2, 'sqrt': 1, 'pow': 1}


# -- a new process
# ----------------------------------------------------------------------------------------

CHILD = r"""
import time
started = time.perf_counter()
import json, resource, sys
from torquefree_ros import load_scene
imported = time.perf_counter()
p = load_scene("explorer1").propagator()
built = time.perf_counter()
p.states([0.01])
done = time.perf_counter()
hwm = [line for line in open("/proc/self/status") if line.startswith("VmHWM:")][0].split()[1]
print(json.dumps({
    "import_s": imported - started, "build_s": built - imported, "sample_s": done - built,
    "inside_s": done - started, "compiled": p.compiled, "numba_imported": "numba" in sys.modules,
    "hwm_mib": int(hwm) / 1024,
    "maxrss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
}))
"""


def _child(kind: str, cache_dir: str | None = None) -> dict:
    env = dict(os.environ)
    env.pop('TORQUEFREE_ROS_KERNELS', None)
    if kind == 'numpy':
        env['TORQUEFREE_ROS_KERNELS'] = 'numpy'
    if cache_dir is not None:
        env['NUMBA_CACHE_DIR'] = cache_dir
    started = time.perf_counter()
    run = subprocess.run(
        [sys.executable, '-c', CHILD],
        env=env,
        check=True,
        capture_output=True,
        text=True,
        cwd=Path(__file__).resolve().parents[1],
    )
    wall = time.perf_counter() - started
    values = json.loads(run.stdout.strip().splitlines()[-1])
    values['wall_s'] = wall
    if values['compiled'] != (kind != 'numpy'):
        raise AssertionError(f'a new process asked for {kind} got compiled={values["compiled"]}')
    return values


def _processes(rounds: int) -> dict:
    _child('cached')  # the cache written (or checked) before anything is timed
    result = {'cached': [], 'numpy': [], 'first use': []}
    for _ in range(rounds):
        result['cached'].append(_child('cached'))
        result['numpy'].append(_child('numpy'))
        with tempfile.TemporaryDirectory() as cache:
            result['first use'].append(_child('first use', cache))
    return result


# -- the report
# -------------------------------------------------------------------------------------------


def _versions() -> str:
    import numba
    import numpy
    import scipy

    def version(name):
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            return 'not installed'

    requires = ', '.join(
        r for r in importlib.metadata.requires('cyrk') or () if 'extra ==' not in r
    )
    return (
        f'python {platform.python_version()}, numpy {numpy.__version__}, '
        f'scipy {scipy.__version__}, numba {numba.__version__} (llvmlite {version("llvmlite")}), '
        f'cyrk {version("cyrk")} (not a dependency of this package; it requires {requires})'
    )


def _report_floor(
    report: Report, cases: list[Case], rounds: list[dict], diagnostics: dict, latencies: dict
) -> None:
    """
    Report the floor of a step against a quarter of cyrk's step.

    Why compiled ≤ 0.25x cyrk is out of reach for a step: the floor of a step (its critical path at
    this machine's latencies) against a quarter of cyrk's step.
    """
    case = next(c for c in cases if c.name == 'explorer1 @ 1e-10')
    d = diagnostics[case.name]
    n = 7 + case.propagator().dynamics.state_size
    path = _critical_path(n)
    floor_ns = sum(path[op] * latencies[op] for op in ('add', 'mul', 'div', 'sqrt', 'pow'))
    cyrk_ns, kernel_ns = d['cyrk_step_us'] * 1e3, d['kernel_step_us'] * 1e3
    cyrk_total = statistics.median(r[case.name, 'cyrk'][0] for r in rounds) / case.duration * 1e6
    steps_only = d['steps'] * floor_ns * 1e-3 / case.duration
    report.add("## How far a step can go: the floor against a quarter of cyrk's")
    report.add('')
    report.add(
        "Both solvers take scipy's steps and call the right-hand side as often (the table above), "
        f'so compiled/cyrk is a ratio of costs per step. A DOP853 step on {case.name.split()[0]} '
        f'(n = {n}, the damper) must run one after the other, however it is coded, at '
        f'least {path["add"]} additions, {path["mul"]} multiplications, {path["div"]} divisions, '
        "a square root and a `pow` (its critical path, counted from scipy's tableau and the "
        'right-hand side: `_critical_path` in this script says which). Latencies measured in this '
        f'run (a chain of dependent operations, compiled): addition {latencies["add"]:.2f} ns, '
        f'multiplication {latencies["mul"]:.2f}, division {latencies["div"]:.2f}, square '
        f'root {latencies["sqrt"]:.2f}, `pow` {latencies["pow"]:.1f}.'
    )
    report.add('')
    report.add("| | ns per step | / cyrk's step |")
    report.add('|---|---|---|')
    report.add(
        f'| the floor: that path, every load, store and other operation free | {floor_ns:.0f} | '
        f'{floor_ns / cyrk_ns:.2f} |'
    )
    report.add(f"| the target: a quarter of cyrk's step | {0.25 * cyrk_ns:.0f} | 0.25 |")
    report.add(
        f"| the compiled path's step (stepping alone, above) | {kernel_ns:.0f} "
        f'| {kernel_ns / cyrk_ns:.2f} |'
    )
    report.add(f"| cyrk's step | {cyrk_ns:.0f} | 1 |")
    report.add('')
    verdict = 'below the floor: out of reach' if 0.25 * cyrk_ns < floor_ns else 'above the floor'
    report.add(
        f"A quarter of cyrk's step is {verdict}; the compiled step is {kernel_ns / floor_ns:.1f}x "
        "the floor. Per simulated second (the table's measure, which also holds the outputs, "
        'where cyrk is slower, and building the propagator): the steps alone at the floor would '
        f'cost {steps_only:.2f} µs per simulated second on {case.name}, against a quarter of '
        f"cyrk's whole run, {0.25 * cyrk_total:.2f} µs."
    )


def _met(value: float, target: float) -> str:
    return 'met' if value <= target else '**not met**'


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().split('\n\n')[0])
    parser.add_argument(
        '--rounds', type=int, default=3, help='rounds of every measurement (default 3)'
    )
    parser.add_argument(
        '--calls', type=int, default=3, help='runs per timing, the fastest kept (default 3)'
    )
    parser.add_argument('--output', help='also write the report to this Markdown file')
    args = parser.parse_args()

    if not switch.AVAILABLE:
        raise SystemExit('numba is not installed: there is no compiled path to measure')
    if importlib.util.find_spec('CyRK') is None:
        raise SystemExit(f'cyrk is not installed: {sys.executable} -m pip install cyrk==0.20.0')
    started = time.monotonic()
    cases = _cases()
    _cyrk_setup()
    _tight_references(cases)
    # warm up (imports, the kernels loaded, cyrk's driver compiled), not measured
    for case in cases:
        for path in PATHS:
            _run(case, path)
    rounds = [_round(cases, args.calls) for _ in range(args.rounds)]
    diagnostics = _diagnostics(cases, args.calls)
    latencies = _latencies(args.calls)
    processes = _processes(args.rounds)
    elapsed = time.monotonic() - started

    report = Report('Motion effects: compiled path, reference path, cyrk', 'make bench-effects')
    report.add(f'- versions: {_versions()}')
    report.add('')
    report.add(
        f'{args.rounds} rounds in {elapsed:.0f} s; each figure is median (min–max) over the '
        f'rounds of the fastest of {args.calls} runs. **CPU time** is `time.process_time()` of '
        'one run from the loaded scene to every sample at 100 Hz (the propagator built, then '
        "`states()` on all the sample times; for cyrk: the scene's Dynamics and the kernels' "
        'model, then its solver), **per simulated second**.'
    )
    report.add('')
    report.add(
        '- **compiled**: the default path, numba kernels (`torquefree_ros/core/integrators`), '
        "DOP853 with scipy's tableau and step control."
    )
    report.add(
        '- **reference**: the same propagator with `kernels.ENABLED = False` (= '
        "`TORQUEFREE_ROS_KERNELS=numpy`): scipy's `DOP853` stepping on the Python right-hand side "
        '`Dynamics.derivative`.'
    )
    report.add(
        "- **cyrk**: `CyRK.nbsolve2_ivp` (cyrk's numba entry point into its C++ solver) with "
        'method `DOP853`, the same rtol/atol, `t_eval` = the sample times, and a numba `cfunc` '
        "right-hand side that calls `motion_kernels.derivative` (the compiled path's own; its "
        "scratch is kept in cyrk's copy of `args`, so no allocation per call). A torque schedule "
        'is solved piece by piece between its breakpoints, each piece with its held torque, as '
        'the propagators do.'
    )
    report.add(
        '- **error**: the largest attitude error (rad; the angle of q_ref* ⊗ q) and |Δω| (rad/s) '
        f'over the samples, against the reference path at rtol {TIGHT_RTOL:g}, '
        f'atol {TIGHT_ATOL:g}. The compiled path at those tolerances lies this far from it (the '
        "measure's floor): "
        + '; '.join(
            f'{c.name} {c.floor["attitude"]:.1e} rad, {c.floor["omega"]:.1e} rad/s' for c in cases
        )
        + '.'
    )
    report.add('')
    report.add(
        "Cases: DOP853 at the scene's accuracy (rtol = accuracy, atol = accuracy / 100: what "
        '`auto` builds); the two torque scenes are built with `scene_from_mapping` (inertia 2, 3, '
        '4 kg m², ω0 = (0.3, 0.2, 1.0) rad/s; torque (0.02, -0.01, 0.03) N m in the inertial '
        'frame; the schedule: 5 segments of 20 s). `detumble` (torque_command) is not here: it '
        'needs a controller answering each sample; its hold goes through the same held-torque '
        'path as external_torque.'
    )
    report.add('')
    report.add(
        '| case | effect | simulated s | rtol / atol | path | µs CPU per simulated s '
        '| attitude error (rad) | |Δω| (rad/s) |'
    )
    report.add('|---|---|---|---|---|---|---|---|')
    for case in cases:
        for path in PATHS:
            values = [r[case.name, path] for r in rounds]
            cost = spread([v[0] / case.duration * 1e6 for v in values])
            attitude = max(v[1] for v in values)
            omega = max(v[2] for v in values)
            report.add(
                f'| {case.name} | {case.effect} | {case.duration:g} '
                f'| {case.rtol:g} / {case.atol:g} | {path} | {cost} '
                f'| {attitude:.1e} | {omega:.1e} |'
            )
    report.add('')
    report.add('## Targets (issue 27; ratios of CPU time taken within each round, case by case)')
    report.add('')
    report.add(
        f'| case | compiled / reference | ≤ {TARGET_REFERENCE:g} | compiled / cyrk | '
        f'≤ {TARGET_CYRK:g} |'
    )
    report.add('|---|---|---|---|---|')
    summary = {'reference': [], 'cyrk': []}
    for case in cases:
        cells = []
        for other, target in (('reference', TARGET_REFERENCE), ('cyrk', TARGET_CYRK)):
            ratios = [r[case.name, 'compiled'][0] / r[case.name, other][0] for r in rounds]
            median = statistics.median(ratios)
            summary[other].append(median <= target)
            cells += [spread(ratios), _met(median, target)]
        report.add(f'| {case.name} | ' + ' | '.join(cells) + ' |')
    e1 = [r['explorer1 @ 1e-10', 'compiled'][0] / 100.0 * 1e6 for r in rounds]
    report.add('')
    report.add(
        f'- explorer1 at rtol 1e-10, atol 1e-12 (100 s, 100 Hz): compiled {spread(e1)} µs of CPU '
        f'per simulated second; target ≤ {TARGET_EXPLORER1_US:g}: '
        f'{_met(statistics.median(e1), TARGET_EXPLORER1_US)}.'
    )
    report.add(
        f'- compiled ≤ {TARGET_REFERENCE:g}x reference: {sum(summary["reference"])} '
        f'of {len(cases)} cases; compiled ≤ {TARGET_CYRK:g}x cyrk: {sum(summary["cyrk"])} '
        f'of {len(cases)} cases.'
    )
    report.add('')
    report.add("## Where the compiled path's time goes")
    report.add('')
    report.add(
        'Per case, the fastest of the calls: building the propagator; `DOP853Kernel.evaluate` '
        'alone from a restart (all the stepping and the dense output, q normalised in each output '
        'row: one numba call, the pieces begun inside it); the rest of `states()` (build + '
        'states() minus the parts, each the fastest of its own calls: it can come out slightly '
        'negative). Then '
        'the stepping alone, for the kernel and for cyrk: the same run asked only for the '
        'breakpoints and the end (no dense output), per step; and the outputs, (all samples − '
        'stepping alone) per sample (dense output and its 3 extra right-hand-side calls per step, '
        "cyrk's storage of the samples; for cyrk also the Dynamics, the q normalisation, the "
        "copy). DOP853 steps: scipy's (`solve_ivp` on the kernels' right-hand side, piece by "
        "piece; the compiled path reproduces scipy's step control and takes these steps) and "
        "cyrk's. Right-hand-side calls of the stepping alone: scipy's `nfev` (the kernel's: 12 an "
        "attempted step, 2 a piece's initial step) and cyrk's (its `pysolve_ivp`, the same C++ "
        "solver, on a Python right-hand side that counts its calls); the stepping's time per call."
    )
    report.add('')
    report.add(
        '| case | build (µs) | kernel evaluate (µs) | rest of states() (µs) '
        '| DOP853 steps (scipy / cyrk) | right-hand-side calls, stepping (scipy / cyrk) '
        '| stepping, µs per step (kernel / cyrk) '
        '| stepping, ns per right-hand-side call (kernel / cyrk) '
        '| outputs, ns per sample (kernel / cyrk) |'
    )
    report.add('|---|---|---|---|---|---|---|---|---|')
    for case in cases:
        d = diagnostics[case.name]
        report.add(
            f'| {case.name} | {d["build_us"]:.0f} | {d["evaluate_us"]:.0f} | '
            f'{d["rest_us"]:.0f} | {d["steps"]:,} / {d["cyrk_steps"]:,} | '
            f'{d["evaluations"]:,} / {d["cyrk_evaluations"]:,} | '
            f'{d["kernel_step_us"]:.2f} / {d["cyrk_step_us"]:.2f} | '
            f'{d["kernel_call_ns"]:.1f} / {d["cyrk_call_ns"]:.1f} | '
            f'{d["kernel_output_ns"]:.0f} / {d["cyrk_output_ns"]:.0f} |'
        )
    report.add('')
    _report_floor(report, cases, rounds, diagnostics, latencies)
    report.add('')
    report.add('## What numba costs a process')
    report.add('')
    report.add(
        "A new process (`python -c`): import `torquefree_ros`, build explorer1's propagator "
        "(`auto`), evaluate one sample. Wall time from outside includes the interpreter's start "
        "and the ROS wheels' re-exec of it (the same in every row); inside: from the child's "
        "first line to its sample. Peak RSS: the child's `VmHWM` (/proc/self/status) at its end; "
        '`resource.getrusage(RUSAGE_SELF).ru_maxrss` in the child is given beside it but is not '
        "the child's own: the child is forked from this (large) benchmark process and Linux "
        "carries that image's high-water mark over `execve` (checked: a `python -c` child reads "
        '~470 MiB of ru_maxrss under a parent holding 480 MiB, 27 under a small one; VmHWM 13 MiB '
        "both times). *cached*: the default, the kernels loaded from numba's cache (written "
        'before); *numpy*: `TORQUEFREE_ROS_KERNELS=numpy`; *first use*: an empty '
        '`NUMBA_CACHE_DIR` (every kernel the run touches compiled).'
    )
    report.add('')
    report.add(
        '| process | wall, outside (s) | inside (s) | import (s) | build propagator (s) '
        '| first sample (s) | numba imported | peak RSS, VmHWM (MiB) | ru_maxrss (MiB) |'
    )
    report.add('|---|---|---|---|---|---|---|---|---|')
    for kind, runs in processes.items():
        report.add(
            f'| {kind} | {spread([r["wall_s"] for r in runs])} '
            f'| {spread([r["inside_s"] for r in runs])} | {spread([r["import_s"] for r in runs])} '
            f'| {spread([r["build_s"] for r in runs])} | {spread([r["sample_s"] for r in runs])} '
            f'| {"yes" if runs[0]["numba_imported"] else "no"} '
            f'| {spread([r["hwm_mib"] for r in runs])} '
            f'| {spread([r["maxrss_mib"] for r in runs])} |'
        )
    cached = statistics.median(r['wall_s'] for r in processes['cached'])
    numpy_wall = statistics.median(r['wall_s'] for r in processes['numpy'])
    rss = statistics.median(r['hwm_mib'] for r in processes['cached']) - statistics.median(
        r['hwm_mib'] for r in processes['numpy']
    )
    first = statistics.median(r['wall_s'] for r in processes['first use'])
    inside = statistics.median(r['inside_s'] for r in processes['cached']) - statistics.median(
        r['inside_s'] for r in processes['numpy']
    )
    report.add('')
    report.add(
        f"numba's cost to a process (medians, cached − numpy): {cached - numpy_wall:+.2f} s of "
        f"wall time ({inside:+.2f} s of it inside the child's own measure; the rest is outside "
        f"it: the interpreter's exit with numba loaded), {rss:+.0f} MiB of peak RSS (VmHWM); the "
        f'first use with an empty cache {first - cached:+.2f} s more than a cached start.'
    )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
