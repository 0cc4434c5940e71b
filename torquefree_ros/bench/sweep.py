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
Run every method over its settings on every case and record error and cost.

Two runs per setting, each on a fresh method (construction included), CPU time by
``time.process_time``; a run shorter than 100 ms is repeated and the best time kept:

* the **stream**: the 100 Hz output over a window of simulated time (the horizon clipped to
  [1 s, 100 s]), giving the cost per simulated second and per output sample;
* the **horizon**: the case's reference samples only (a sparse output over its whole horizon),
  giving the largest attitude error (rad) and relative rate error, and the cost of reaching the
  horizon.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
import time

import numpy as np

from .cases import Case
from .methods import Method, OUTPUT_PERIOD
from ..core.propagators import make_propagator, MAX_STEPS_PER_SAMPLE
from ..core.run.accuracy import trajectory_errors
from ..core.scene.loader import scene_from_mapping

WINDOW_LIMITS = (1.0, 100.0)  # s
#: a sweep stops tightening a method on a case once a run takes longer than this (CPU s)
RUN_LIMIT = {False: 10.0, True: 2.0}  # by smoke
#: fixed-step methods skip a setting that needs more steps than this:
#: ours (Python), MuJoCo (compiled); ours also one that needs more than ``MAX_STEPS_PER_SAMPLE``
#: between two reference samples (the propagators refuse it: a dominant rotor's fine steps)
STEP_LIMIT = {'torquefree_ros': 1e6, 'mujoco': 5e6}
_REPEAT_BELOW = 0.1  # s
_REPEAT_TOTAL = 0.5  # s


@dataclass
class Measurement:
    case: str
    method: str
    family: str
    setting_name: str
    setting: float | None
    attitude_error_rad: float
    rate_error_rel: float
    attitude_floor_rad: float
    cpu_us_per_sim_s: float
    cpu_us_per_sample: float
    cpu_ms_to_horizon: float
    samples: int
    window_s: float
    horizon_s: float
    status: str  # ok | failed: ... | skipped: ...

    @classmethod
    def columns(cls) -> list[str]:
        return [f.name for f in fields(cls)]

    def row(self) -> dict:
        return asdict(self)

    @property
    def ok(self) -> bool:
        return self.status == 'ok'


def cpu_seconds(run):
    """``(best CPU seconds, result)``: one run, or the best of repeats for a short one."""
    start = time.process_time()
    result = run()
    best = time.process_time() - start
    total = best
    while best < _REPEAT_BELOW and total < _REPEAT_TOTAL:
        start = time.process_time()
        run()
        elapsed = time.process_time() - start
        best, total = min(best, elapsed), total + elapsed
    return best, result


def cost_window(case: Case) -> float:
    low, high = WINDOW_LIMITS
    return min(max(case.horizon, low), high)


def measure(method: Method, case: Case, setting) -> tuple[Measurement, float]:
    """One measurement and the CPU seconds it took (all runs)."""
    window = cost_window(case)
    grid = np.arange(int(round(window / OUTPUT_PERIOD)) + 1) * OUTPUT_PERIOD
    record = {
        'case': case.name,
        'method': method.label,
        'family': method.family,
        'setting_name': method.setting_name,
        'setting': setting,
        'attitude_floor_rad': float(case.attitude_floor.max()),
        'window_s': window,
        'horizon_s': case.horizon,
    }
    spent = 0.0
    try:
        stream_cpu, _ = cpu_seconds(lambda: method.run(case, setting, grid))
        spent += stream_cpu
        horizon_cpu, (omega, q) = cpu_seconds(lambda: method.run(case, setting, case.times))
        spent += horizon_cpu
        rate, attitude = trajectory_errors(omega, q, case.omega, case.q)
        errors = (float(attitude.max()), float(rate.max()))
        status = 'ok' if np.all(np.isfinite(errors)) else 'failed: non-finite result'
    except Exception as error:  # noqa: BLE001 - a method that fails is a result, reported as such
        return Measurement(
            **record,
            attitude_error_rad=np.nan,
            rate_error_rel=np.nan,
            cpu_us_per_sim_s=np.nan,
            cpu_us_per_sample=np.nan,
            cpu_ms_to_horizon=np.nan,
            samples=0,
            status=f'failed: {error}',
        ), spent
    return Measurement(
        **record,
        attitude_error_rad=errors[0],
        rate_error_rel=errors[1],
        cpu_us_per_sim_s=stream_cpu / window * 1e6,
        cpu_us_per_sample=stream_cpu / grid.size * 1e6,
        cpu_ms_to_horizon=horizon_cpu * 1e3,
        samples=int(grid.size),
        status=status,
    ), spent


def sweep(methods, cases, smoke: bool = False, progress=None) -> list[Measurement]:
    """
    Measure every method x case x setting, settings from cheap to expensive.

    A method runs only the cases it applies to (no row for the others: the free body's exact
    solution on a gyrostat, say). A method stops on a case at the first setting over budget
    (recorded as skipped, like the tighter ones after it).
    """
    _warm_up(gyrostat=any(case.effects for case in cases))
    results = []
    for case in cases:
        span = max(case.horizon, cost_window(case))
        for method in methods:
            if not method.applies(case):
                continue
            over_budget = None
            for setting in method.settings(case, smoke):
                if over_budget is None and method.steps is not None:
                    steps = method.steps(case, setting, span)
                    limit = STEP_LIMIT[method.family]
                    if steps > limit:
                        over_budget = f'skipped: {steps:.1e} steps over the limit {limit:.0e}'
                    elif method.family == 'torquefree_ros':
                        # our propagators refuse more steps than this between two samples
                        gap = float(np.max(np.diff(case.times), initial=OUTPUT_PERIOD))
                        between = method.steps(case, setting, gap)
                        if between > MAX_STEPS_PER_SAMPLE:
                            over_budget = (
                                f'skipped: {between:.1e} steps between reference samples, over '
                                f'the bound per sample {MAX_STEPS_PER_SAMPLE:,}'
                            )
                if over_budget:
                    results.append(_skipped(method, case, setting, over_budget))
                    continue
                result, spent = measure(method, case, setting)
                results.append(result)
                if progress:
                    progress(result)
                if spent > RUN_LIMIT[smoke]:
                    over_budget = f'skipped: the previous setting took {spent:.0f} s CPU'
    return results


def _warm_up(gyrostat: bool = False) -> None:
    """
    Evaluate each kind of exact motion once before anything is timed.

    A process loads the compiled kernels once (or compiles them, the first time after an install),
    which is not a propagator's cost. ``gyrostat``: the exact gyrostat's too (a rotor, and a
    coasting wheel whose angle integrates the rates), and the effects' right-hand side.
    """
    if gyrostat:
        wheel = {
            'axis': [0.0, 0.0, 1.0],
            'spin_inertia': 0.2,
            'max_torque': 0.1,
            'max_speed': 1000.0,
            'speed': 20.0,
        }
        for effect in (
            {'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 1.0]}},
            {'reaction_wheels': {'wheels': [wheel]}},
        ):
            scene = scene_from_mapping(
                {
                    'body': {'inertia': [1.0, 2.0, 3.0]},
                    'initial': {'angular_velocity': [0.3, 0.5, -0.4]},
                    'effects': [effect],
                }
            )
            for name in ('gyrostat', 'dop853'):
                scene.propagator(name).states(np.array([0.0, 1.0]))
    # m <= 1/2, m > 1/2, the separatrix
    for inertia, rate in (
        ([1.0, 2.0, 3.0], [0.3, 0.2, 1.0]),
        ([2.0, 3.0, 4.0], [0.7, 0.5, 0.6]),
        ([3.0, 4.0, 6.0], [2.0, 0.5, 1.0]),
    ):
        make_propagator(inertia, rate, [0.0, 0.0, 0.0, 1.0])([0.0, 1.0])


def _skipped(method, case, setting, reason) -> Measurement:
    return Measurement(
        case.name,
        method.label,
        method.family,
        method.setting_name,
        setting,
        np.nan,
        np.nan,
        float(case.attitude_floor.max()),
        np.nan,
        np.nan,
        np.nan,
        0,
        cost_window(case),
        case.horizon,
        reason,
    )
