"""The scene library: the YAML files in ``torquefree_ros/scenes/``, shipped inside the package (so a
source checkout, a wheel and a colcon install all find them the same way) and also installed under
``share/torquefree_ros/config/scenes`` for ROS users to browse."""

from __future__ import annotations

from pathlib import Path

LIBRARY_DIRECTORY = Path(__file__).resolve().parent.parent / "scenes"


def library_scenes() -> dict[str, Path]:
    """Name -> file of every library scene."""
    return {path.stem: path for path in sorted(LIBRARY_DIRECTORY.glob("*.yaml"))}


def is_scene_name(text: str) -> bool:
    """A bare name (``explorer1``) rather than a path (``./explorer1``, ``a/b.yaml``, ``x.yaml``)."""
    return bool(text) and "/" not in text and "\\" not in text and not text.endswith((".yaml", ".yml"))
