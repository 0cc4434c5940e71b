"""The README's Python quick tour runs as written, and says what it prints."""

from __future__ import annotations

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_the_quick_tour_runs_as_written():
    text = README.read_text(encoding="utf-8")
    tour = text[text.index("## Quick tour"):]
    code = re.search(r"```python\n(.*?)```", tour, re.S).group(1)
    namespace: dict = {}
    exec(compile(code, "README quick tour", "exec"), namespace)  # noqa: S102 - our own README
    assert namespace["w"].shape[0] == namespace["times"].size
    assert namespace["W"].shape == (1000, 601, 3) and namespace["Q"].shape == (1000, 601, 4)
    summary = namespace["RigidBody"].from_inertia([1.0, 2.0, 3.0]).classify([1e-4, 1.0, 1e-4]).summary()
    assert f"# '{summary}'" in code  # the output the tour shows is the output it gives


def test_the_example_test_shown_is_the_example_test():
    text = README.read_text(encoding="utf-8")
    section = text[text.index("### Testing your node against torquefree_ros"):]
    shown = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    assert shown == (README.parent / "examples" / "test_attitude_estimator.py").read_text(encoding="utf-8")
