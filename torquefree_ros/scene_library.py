"""The scene library: the scenes installed with the package (``config/scenes/*.yaml``), found by
name in a source checkout or through the ament index / this Python's prefix once installed."""

from __future__ import annotations

from pathlib import Path

from .bag.definitions import DefinitionError, share_directory
from .core.scene import Scene, SceneError, default_scene, load_scene

SOURCE_SCENES = Path(__file__).resolve().parent.parent / "config" / "scenes"


def scene_directories():
    if SOURCE_SCENES.is_dir():
        yield SOURCE_SCENES  # a source checkout
    try:
        yield share_directory("torquefree_ros") / "config" / "scenes"  # an installed package
    except DefinitionError:
        pass


def installed_scenes() -> dict[str, Path]:
    """Name -> file of every library scene (the first directory that has a name wins)."""
    found: dict[str, Path] = {}
    for directory in scene_directories():
        if directory.is_dir():
            for path in sorted(directory.glob("*.yaml")):
                found.setdefault(path.stem, path)
    return found


def resolve_scene(name: str) -> Scene:
    """A scene file, or the name of a library scene (``default`` = the built-in default)."""
    path = Path(name)
    if path.is_file() or path.suffix in (".yaml", ".yml") or "/" in name:
        return load_scene(path)
    if name == "default":
        return default_scene()
    library = installed_scenes()
    if name in library:
        return load_scene(library[name])
    known = ", ".join(sorted(library)) or "none installed"
    raise SceneError(f"scene: '{name}' is neither a file nor a library scene (library: {known})")
