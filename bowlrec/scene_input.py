"""The one way in for a scene: what a user gives becomes a validated scene, or one clear error.

Every front end takes its scenes here: :func:`bowlrec.simulate` (through
:func:`bowlrec.api.as_scene`), the command line, the HTTP service, batch jobs (their base scene
and the scenes they list) and sessions (each bowler's scene). A scene is given as

* a path to a ``.json``, ``.yaml`` or ``.yml`` file (:func:`check_scene_input`,
  :func:`parse_scene_input`, :func:`parse_scene_file`; never :func:`parse_scene`, which the
  service calls on request bodies and which reads no file);
* a mapping (a request body, an inline scene of a job or session): a physical
  :class:`~bowlrec.spec.Scene`, or a bowler-language :class:`~bowlrec.bowling.scene.BowlerScene`
  when its top level says ``"format": "bowler"``;
* a :class:`~bowlrec.spec.Scene` or :class:`~bowlrec.bowling.scene.BowlerScene` object.

A string ``ball`` names a ball of an archive's library (``"name"`` or ``"name@version"``): a
physical ball goes into a physical scene, a spec sheet (bowlers' units, ``weight_lb``) into a
bowler scene, which then lays it out by its layout and PAP.

Two steps: :func:`check_scene` validates what was given (a :class:`CheckedScene`: the scene
model, bowler or physical, and the library ball it used); :meth:`CheckedScene.parsed` converts a
bowler scene into the physical scene the kernel runs (a :class:`ParsedScene`). Batch jobs and
sessions keep the checked model (their sweeps and shots work on it); everything else takes the
parsed scene.

Every problem is a :class:`~bowlrec.errors.SceneInputError` (an
:class:`~bowlrec.errors.InputError` and a ``ValueError``), never a bare Pydantic error: one line
per problem, naming the field (``delivery.speed_mps: Input should be greater than 0 (got
-1.0)``), each line prefixed with the file's path when the scene came from a file. Batch jobs
raise the same lines as a :class:`~bowlrec.errors.JobError`, prefixed with where the job names
the scene (``base: ...``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias

from bowlrec.errors import BallNotFoundError, SceneInputError, SpecFileError

if TYPE_CHECKING:
    from pydantic import BaseModel

    from bowlrec.bowling.scene import BowlerScene
    from bowlrec.spec import Scene

__all__ = [
    "BallEntryView",
    "BallLookup",
    "BallSource",
    "CheckedScene",
    "ParsedScene",
    "SceneInputError",
    "SceneSource",
    "check_scene",
    "check_scene_input",
    "is_bowler",
    "library_lookup",
    "parse_scene",
    "parse_scene_file",
    "parse_scene_input",
    "prefix_lines",
    "read_scene_mapping",
    "with_library_ball",
]

#: a library lookup: "name" or "name@version" -> (ball spec as a mapping, "name@version")
BallLookup = Callable[[str], tuple[dict[str, Any], str]]


class BallEntryView(Protocol):
    """One version of a library ball, as the intake reads it: the spec and its
    ``name@version``."""

    @property
    def ball(self) -> BaseModel: ...

    @property
    def ref(self) -> str: ...


class BallSource(Protocol):
    """A ball library as the intake reads it (an archive's
    :class:`~bowlrec.archive.BallLibrary` is one): ``get("name")`` or
    ``get("name@version")``; BallNotFoundError (or ValueError) when there is no such ball."""

    def get(self, ref: str) -> BallEntryView: ...


#: a scene as a user gives it: a model, a mapping, or a path to a .json/.yaml/.yml file
SceneSource: TypeAlias = "Scene | BowlerScene | Mapping[str, Any] | str | os.PathLike[str]"


@dataclass(frozen=True)
class ParsedScene:
    """A validated physical scene, the bowler scene it came from (None for a physical one)
    and the library ball it referenced (``name@version``), if any."""

    scene: Scene
    ball_ref: str | None = None
    bowler: BowlerScene | None = None


@dataclass(frozen=True)
class CheckedScene:
    """A validated scene as given, not converted: ``model`` is the physical
    :class:`~bowlrec.spec.Scene` or the :class:`~bowlrec.bowling.scene.BowlerScene`;
    ``ball_ref`` the library ball it used (``name@version``), if any."""

    model: Scene | BowlerScene
    ball_ref: str | None = None

    @property
    def is_bowler(self) -> bool:
        """True for a bowler-language scene."""
        from bowlrec.spec import Scene

        return not isinstance(self.model, Scene)

    def parsed(self, what: str = "scene") -> ParsedScene:
        """The physical scene (a bowler scene converted: laid out, its target at the arrows
        solved); SceneInputError when a bowler scene has no valid physical scene (an illegal
        ball, an unreachable target, ...). ``what`` names the input in those messages."""
        from pydantic import ValidationError

        from bowlrec.spec import Scene, format_validation_error

        if isinstance(self.model, Scene):
            return ParsedScene(self.model, self.ball_ref)
        try:
            return ParsedScene(self.model.to_scene(), self.ball_ref, self.model)
        except ValidationError as err:  # valid bowler fields whose physical scene is not
            lines = format_validation_error(err).splitlines()
            raise SceneInputError(
                "\n".join(f"{what}: the physical scene of this bowler scene: {x}" for x in lines)
            ) from None
        except ValueError as err:  # a bowler scene that cannot be placed (an illegal ball, ...)
            raise SceneInputError(f"{what}: {err}") from None


#: top-level fields only a bowler-language scene has
_BOWLER_ONLY = frozenset({"layout", "pap", "pattern", "balance", "rules", "allow_illegal"})


def prefix_lines(prefix: object, text: str) -> str:
    """Every line of ``text`` as ``"<prefix>: <line>"`` (one error per line, each naming the
    file or the place it came from, like a compiler's messages)."""
    return "\n".join(f"{prefix}: {line}" for line in text.splitlines())


@contextmanager
def _prefixed(prefix: object) -> Iterator[None]:
    """Within: a SceneInputError gets ``prefix`` on every line."""
    try:
        yield
    except SceneInputError as err:
        raise SceneInputError(prefix_lines(prefix, str(err))) from None


def is_bowler(data: Any) -> bool:
    """True for a bowler-language scene mapping (top level ``"format": "bowler"``)."""
    return isinstance(data, Mapping) and data.get("format") == "bowler"


def is_spec_sheet(spec: Mapping[str, Any]) -> bool:
    """True for a bowler spec sheet (bowlers' units), False for a physical ball spec."""
    return "weight_lb" in spec


def library_lookup(balls: BallSource | None) -> BallLookup:
    """A :data:`BallLookup` over a ball library (an archive's)."""

    def lookup(ref: str) -> tuple[dict[str, Any], str]:
        if balls is None:
            raise SceneInputError(f"ball: library ball {ref!r}: no archive (ball library) here")
        try:
            entry = balls.get(ref)
        except (BallNotFoundError, ValueError) as err:
            raise SceneInputError(f"ball: {err}") from None
        return entry.ball.model_dump(mode="json"), entry.ref

    return lookup


def with_library_ball(
    data: Mapping[str, Any], lookup: BallLookup | None
) -> tuple[dict[str, Any], str | None]:
    """The scene mapping with a string ``ball`` replaced by the library's spec, and the
    reference used (None when the ball is given inline)."""
    ref = data.get("ball")
    if not isinstance(ref, str):
        return dict(data), None
    if lookup is None:
        raise SceneInputError("ball: library references are not available here")
    spec, used = lookup(ref)
    sheet, bowler = is_spec_sheet(spec), is_bowler(data)
    if sheet != bowler:
        kind = "a spec sheet (bowlers' units)" if sheet else "a physical ball"
        scene = "a bowler-language" if bowler else "a physical"
        hint = (
            " (a spec sheet needs the layout and PAP of a bowler scene: format: bowler)"
            if sheet
            else ""
        )
        raise SceneInputError(
            f"ball: library ball {used} is {kind}; it cannot be used in {scene} scene{hint}"
        )
    return {**data, "ball": spec}, used


def read_scene_mapping(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The mapping a scene file (.json, .yaml, .yml) holds, not validated. SceneInputError,
    its message starting with the path, when the file is missing or unreadable, is not valid
    JSON/YAML (:func:`bowlrec.spec.loading.read_mapping` says what and where), or holds no
    mapping."""
    from bowlrec.spec.loading import read_mapping

    p = Path(path)
    try:
        data = read_mapping(p)
    except FileNotFoundError:
        raise SceneInputError(f"{p}: no such file") from None
    except IsADirectoryError:
        raise SceneInputError(f"{p}: a directory, not a scene file") from None
    except OSError as err:
        raise SceneInputError(f"{p}: {err.strerror or err}") from None
    except SpecFileError as err:
        raise SceneInputError(f"{p}: {err}") from None
    if not isinstance(data, dict):
        raise SceneInputError(
            f"{p}: scene: expected a mapping (JSON object), got {type(data).__name__}"
        )
    return data


def check_scene(
    data: Any,
    balls: BallSource | BallLookup | None = None,
    *,
    bowler: bool | None = None,
    what: str = "scene",
) -> CheckedScene:
    """Validate a scene mapping (or take a Scene or BowlerScene as it is); reads no file.

    ``balls``: an archive's ball library, or a lookup, for a string ``ball`` (None: library
    references are an error). ``bowler``: None reads a mapping as a bowler scene when it says
    ``"format": "bowler"`` and as a physical one otherwise; True asks for a bowler scene (a
    mapping without ``format`` is read as one). ``what`` names the input in messages about its
    shape. SceneInputError with one field-named line per problem."""
    from pydantic import ValidationError

    from bowlrec.spec import Scene, format_validation_error
    from bowlrec.spec.errors import printable

    if isinstance(data, Scene):
        if bowler:
            raise SceneInputError(f"{what}: a bowler scene is needed, got a physical Scene")
        return CheckedScene(data)
    if not isinstance(data, Mapping):
        from bowlrec.bowling.scene import BowlerScene  # loaded for bowler scenes only

        if isinstance(data, BowlerScene):
            return CheckedScene(data)
        raise SceneInputError(
            f"{what}: expected a mapping (JSON object), got {type(data).__name__}"
        )
    from bowlrec.file_kinds import wrong_kind

    other = wrong_kind(data, "bowler" if bowler else "scene", "bowler", "scene")
    if other is not None:
        raise SceneInputError(other)
    if bowler and "format" not in data:
        data = {"format": "bowler", **data}
    if "format" in data and data["format"] != "bowler":
        wanted = "" if bowler else ", or left out (a physical scene)"
        raise SceneInputError(
            printable(
                f"format: Input should be 'bowler' (a bowler-language scene){wanted} "
                f"(got {data['format']!r})"
            )
        )
    lookup = balls if callable(balls) else library_lookup(balls) if balls is not None else None
    data, ball_ref = with_library_ball(data, lookup)
    try:
        if not is_bowler(data):
            return CheckedScene(Scene.model_validate(data), ball_ref)
        from bowlrec.bowling.scene import BowlerScene

        return CheckedScene(BowlerScene.model_validate(data), ball_ref)
    except ValidationError as err:
        text = format_validation_error(err)
        hint = sorted(_BOWLER_ONLY & set(data)) if not is_bowler(data) else []
        if hint:  # the unknown fields are the bowler ones a physical scene does not have
            others = [x for x in text.splitlines() if "Extra inputs are not permitted" not in x]
            text = "\n".join(
                [
                    f"format: missing; {', '.join(hint)} belong to a bowler-language scene: "
                    'add "format": "bowler"',
                    *others,
                ]
            )
        raise SceneInputError(text) from None


def parse_scene(
    data: Any, balls: BallSource | BallLookup | None = None, *, what: str = "scene"
) -> ParsedScene:
    """Validate a scene mapping (physical or bowler-language; library balls resolved through
    ``balls``, a library or a lookup), or take a Scene or BowlerScene, into the physical scene
    (:func:`check_scene`, then :meth:`CheckedScene.parsed`). Reads no file: what the service
    calls on request bodies. ``what`` names the input in messages about its shape."""
    return check_scene(data, balls, what=what).parsed(what)


def _as_path(source: Any, base_dir: str | os.PathLike[str] | None) -> Path | None:
    """The file a source names (relative to ``base_dir`` when given), None for a model or a
    mapping."""
    if not isinstance(source, str | os.PathLike):
        return None
    path = Path(source)
    return path if base_dir is None else Path(base_dir) / path


def check_scene_input(
    source: SceneSource,
    balls: BallSource | BallLookup | None = None,
    *,
    base_dir: str | os.PathLike[str] | None = None,
    bowler: bool | None = None,
) -> CheckedScene:
    """:func:`check_scene` of a scene given any way: a path to a .json/.yaml/.yml file
    (relative to ``base_dir`` when given; every line of a message starts with the path), a
    mapping, a Scene or a BowlerScene."""
    path = _as_path(source, base_dir)
    if path is None:
        return check_scene(source, balls, bowler=bowler)
    data = read_scene_mapping(path)
    with _prefixed(path):
        return check_scene(data, balls, bowler=bowler)


def parse_scene_input(
    source: SceneSource,
    balls: BallSource | BallLookup | None = None,
    *,
    base_dir: str | os.PathLike[str] | None = None,
    warn: Callable[[str], None] | None = None,
) -> ParsedScene:
    """The physical scene of a scene given any way (:func:`check_scene_input`, then
    :meth:`CheckedScene.parsed`); what :func:`bowlrec.simulate` and the command line use.
    ``warn`` gets each value that looks typed in another unit
    (:func:`bowlrec.spec.unit_sense.unit_warnings`), prefixed with the file's path, before
    the scene is converted (so the warning comes before a conversion that fails because of
    the value)."""
    checked = check_scene_input(source, balls, base_dir=base_dir)
    path = _as_path(source, base_dir)
    if warn is not None:
        from bowlrec.spec.unit_sense import unit_warnings

        for line in unit_warnings(checked.model):
            warn(line if path is None else f"{path}: {line}")
    if path is None:
        return checked.parsed()
    with _prefixed(path):
        return checked.parsed()


def parse_scene_file(
    path: str | os.PathLike[str],
    balls: BallSource | BallLookup | None = None,
    *,
    warn: Callable[[str], None] | None = None,
) -> ParsedScene:
    """Read and parse a scene file (.json, .yaml, .yml): :func:`parse_scene_input` of a path;
    SceneInputError prefixed with the path when it cannot be read or is invalid."""
    return parse_scene_input(Path(path), balls, warn=warn)
