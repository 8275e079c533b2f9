"""The scenes shipped with hertzmap: the study files of the repo's scenes/ folder, installed as
package data of ``hertzmap.scenes``, so that ``hertzmap run default`` works from any folder.

A study argument is a path when a file of that name exists, else the name of a scene.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from hertzmap.study.spec import Study, StudyError, load_study

#: the package the scenes are installed in (pyproject.toml maps it to scenes/)
SCENES_PACKAGE = "hertzmap.scenes"
SUFFIX = ".toml"


def scene_paths() -> dict[str, Path]:
    """Every shipped scene: name -> its study file, sorted by name."""
    folder = Path(str(resources.files(SCENES_PACKAGE)))
    return {p.stem: p for p in sorted(folder.glob("*" + SUFFIX))}


def study_path(arg: str | Path) -> Path:
    """The study file ``arg`` names: an existing file, else the scene of that name (``default``
    or ``default.toml``, with no folder), else ``arg`` itself (reading it then says why not)."""
    path = Path(arg)
    if path.is_file() or path.parent != Path("."):
        return path
    return scene_paths().get(path.name.removesuffix(SUFFIX), path)


def load_scene_or_file(arg: str | Path) -> Study:
    """load_study of study_path(arg); a bare name that is neither a file nor a scene gets the
    scenes named in its error."""
    path = study_path(arg)
    try:
        return load_study(path)
    except StudyError as exc:
        if exc.field != "file" or Path(arg).parent != Path(".") or path.is_file():
            raise
        scenes = ", ".join(scene_paths())
        raise StudyError("file", f"{str(exc).removeprefix('file: ')}; nor is it a scene "
                                 f"({scenes}; hertzmap scenes describes them)") from None
