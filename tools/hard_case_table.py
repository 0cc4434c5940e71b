#!/usr/bin/env python3
"""Per hard case: each propagator's worst attitude error (rad), worst relative rate error and cost
(µs per sample), with scipy's ``solve_ivp(DOP853, rtol=1e-12)`` beside them, measured in one run
against test/data/hard_cases.json. Fixed-step methods take 1000 steps per rotation (2 pi/|w|).
A benchmark script, not a test: it prints what it measured and the machine it ran on."""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np
import scipy
from scipy.integrate import solve_ivp

from torquefree_ros import make_propagator
from torquefree_ros.core import quaternion
from torquefree_ros.core.accuracy import trajectory_errors

DATA = Path(__file__).resolve().parent.parent / "test" / "data" / "hard_cases.json"


def settings(name, case):
    speed = float(np.linalg.norm(case["angular_velocity"])) or 1.0
    return {"step": 2 * np.pi / speed / 1000} if name in ("rk4", "lie_rk4") else (
        {"rtol": 1e-12, "atol": 1e-14} if name == "dop853" else {})


def scipy_dop853(case, times):
    I = np.asarray(case["inertia"], float)

    def rhs(t, y):
        w, q = y[:3], y[3:]
        w_dot = np.array([(I[1] - I[2]) * w[1] * w[2] / I[0], (I[2] - I[0]) * w[2] * w[0] / I[1], (I[0] - I[1]) * w[0] * w[1] / I[2]])
        return np.concatenate([w_dot, 0.5 * quaternion.multiply(q, np.append(w, 0.0))])

    y0 = np.concatenate([case["angular_velocity"], case["orientation"]])
    sol = solve_ivp(rhs, (0.0, times[-1]), y0, method="DOP853", t_eval=times, rtol=1e-12, atol=1e-14)
    q = sol.y[3:].T
    return sol.y[:3].T, q / np.linalg.norm(q, axis=1, keepdims=True)


def main():
    cases = json.loads(DATA.read_text())["cases"]
    methods = ["analytic", "lie_rk4", "rk4", "dop853", "scipy DOP853 1e-12"]
    print(f"# machine: {platform.platform()}, {platform.processor() or platform.machine()}, "
          f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}")
    print("| case | floor (rad) | " + " | ".join(f"{m}: att err / rate err / µs" for m in methods) + " |")
    print("|---|---|" + "---|" * len(methods))
    for case in cases:
        times = np.asarray(case["times"])
        cells = []
        for m in methods:
            start = time.perf_counter()
            if m.startswith("scipy"):
                w, q = scipy_dop853(case, times)
            else:
                w, q = make_propagator(case["inertia"], case["angular_velocity"], case["orientation"], m, **settings(m, case))(times)
            cost = (time.perf_counter() - start) / times.size * 1e6
            rate, att = (e.max() for e in trajectory_errors(w, q, case["omega"], case["q"]))
            cells.append(f"{att:.1e} / {rate:.1e} / {cost:.0f}")
        print(f"| {case['name']} | {max(case['attitude_floor']):.0e} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
