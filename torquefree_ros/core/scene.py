"""Scenes: a body, its initial state and the effects it calls for, read from YAML.

Every error names the file and the path of the offending field (``body.inertia``, ``effects[1]``) and
says what is wrong. The built-in default scene lives here, so it needs no file at run time;
``config/scenes/default.yaml`` is the same scene as a file (a test keeps the two equal).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from .rigid_body import RigidBody
from .validation import finite_vector, unit_quaternion

DEFAULT_SCENE_DATA = {
    "description": "a triaxial body tumbling visibly about its minor axis (the built-in default scene)",
    "body": {"inertia": [3.0, 2.0, 1.0]},
    "initial": {"angular_velocity": [0.3, 0.2, 1.0], "orientation": [0.0, 0.0, 0.0, 1.0]},
    "effects": [],
}

_SCENE_KEYS = {"description": str, "body": dict, "initial": dict, "effects": list}
_BODY_KEYS = ("inertia",)
_INITIAL_KEYS = ("angular_velocity", "orientation")
#: effect name -> class; filled when effects exist (none yet: every scene is torque-free)
EFFECTS: dict[str, type] = {}


class SceneError(ValueError):
    """A scene that cannot be used; the message starts with the file and the field path."""


@dataclass(frozen=True)
class Scene:
    inertia: tuple  # as written: 3 principal moments or 6 tensor elements (kg m^2)
    angular_velocity: tuple  # body frame, rad/s
    orientation: tuple  # q_NB as (x, y, z, w)
    effects: tuple = ()
    description: str = ""
    source: str = "<built-in default>"

    @property
    def torque_free(self) -> bool:
        return not self.effects


def default_scene() -> Scene:
    return scene_from_mapping(DEFAULT_SCENE_DATA)


def load_scene(path) -> Scene:
    """Read and validate a scene file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise SceneError(f"scene: cannot read {str(path)!r}: {error.strerror or error}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise SceneError(f"{path}: not valid YAML: {error}") from None
    return scene_from_mapping(data, source=str(path))


def scene_from_mapping(data, source: str = "<built-in default>") -> Scene:
    def fail(where: str, reason: str):
        raise SceneError(f"{source}: {where}: {reason}")

    if not isinstance(data, dict):
        fail("(top level)", f"expected a mapping with keys {', '.join(_SCENE_KEYS)}, got {type(data).__name__}")
    _check_keys(data, tuple(_SCENE_KEYS), "", fail)
    for key, kind in _SCENE_KEYS.items():
        if key in data and not isinstance(data[key], kind):
            fail(key, f"expected a {_KIND_NAMES[kind]}, got {type(data[key]).__name__}")
    for key in ("body", "initial"):
        if key not in data:
            fail(key, "missing (every scene names its body and initial state)")
    body, initial = data["body"], data["initial"]
    _check_keys(body, _BODY_KEYS, "body.", fail)
    _check_keys(initial, _INITIAL_KEYS, "initial.", fail)
    if "inertia" not in body:
        fail("body.inertia", "missing")
    if "angular_velocity" not in initial:
        fail("initial.angular_velocity", "missing")

    def checked(where: str, check, value):
        try:
            return check(value)
        except ValueError as error:
            fail(where, str(error).split(": ", 1)[-1])

    inertia = checked("body.inertia", lambda v: _numbers(v, (3, 6)), body["inertia"])
    checked("body.inertia", RigidBody.from_inertia, inertia)
    omega = checked("initial.angular_velocity", lambda v: _numbers(v, (3,)), initial["angular_velocity"])
    q = checked("initial.orientation", lambda v: unit_quaternion(_numbers(v, (4,))),
                initial.get("orientation", [0.0, 0.0, 0.0, 1.0]))
    effects = data.get("effects") or []
    for index, entry in enumerate(effects):
        if not (isinstance(entry, dict) and len(entry) == 1):
            fail(f"effects[{index}]", "expected a one-key mapping '- NAME: {parameters}'")
        (name,) = entry
        if name not in EFFECTS:
            known = ", ".join(sorted(EFFECTS)) or "none yet: scenes are torque-free"
            fail(f"effects[{index}]", f"unknown effect {name!r} (known: {known})")
    return Scene(
        inertia=tuple(float(x) for x in inertia),
        angular_velocity=tuple(float(x) for x in omega),
        orientation=tuple(float(x) for x in q),
        effects=tuple(effects),
        description=str(data.get("description", "")),
        source=source,
    )


_KIND_NAMES = {str: "string", dict: "mapping", list: "list"}


def _numbers(value, lengths) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or not all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in value
    ):
        raise ValueError(f"expected a list of numbers, got {value!r}")
    return finite_vector(value, "value", lengths)


def _check_keys(mapping: dict, allowed, prefix: str, fail) -> None:
    for key in mapping:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), allowed, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f" (allowed: {', '.join(allowed)})"
            fail(f"{prefix}{key}", f"unknown key{hint}")
