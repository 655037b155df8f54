"""Scenes as users give them: one parser for the CLI, the service, batch jobs and the Python API.

A scene is a mapping (from a file, a request body or a job): a physical
:class:`~bowlrec.spec.Scene`, or a bowler-language
:class:`~bowlrec.bowling.scene.BowlerScene` when its top level says ``"format": "bowler"``.
A string ``ball`` names a ball of an archive's library (``"name"`` or ``"name@version"``): a
physical ball goes into a physical scene, a spec sheet (bowlers' units, ``weight_lb``) into a
bowler scene, which then lays it out by its layout and PAP.

:func:`parse_scene` validates and converts; every problem is a :class:`SceneInputError` whose
message names the field (``ball: ...``, ``delivery.speed_mps: ...``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.errors import BallNotFoundError, SceneInputError

if TYPE_CHECKING:
    from bowlrec.archive import BallLibrary
    from bowlrec.bowling.scene import BowlerScene
    from bowlrec.spec import Scene

__all__ = [
    "BallLookup",
    "ParsedScene",
    "SceneInputError",
    "is_bowler",
    "library_lookup",
    "parse_scene",
    "parse_scene_file",
]

#: a library lookup: "name" or "name@version" -> (ball spec as a mapping, "name@version")
BallLookup = Callable[[str], tuple[dict[str, Any], str]]


@dataclass(frozen=True)
class ParsedScene:
    """A validated physical scene, the bowler scene it came from (None for a physical one)
    and the library ball it referenced (``name@version``), if any."""

    scene: Scene
    ball_ref: str | None = None
    bowler: BowlerScene | None = None


#: top-level fields only a bowler-language scene has
_BOWLER_ONLY = frozenset({"layout", "pap", "pattern", "balance", "rules", "allow_illegal"})


def prefix_lines(prefix: object, text: str) -> str:
    """Every line of ``text`` as ``"<prefix>: <line>"`` (one error per line, each naming the
    file, like a compiler's messages)."""
    return "\n".join(f"{prefix}: {line}" for line in text.splitlines())


def is_bowler(data: Any) -> bool:
    """True for a bowler-language scene mapping (top level ``"format": "bowler"``)."""
    return isinstance(data, Mapping) and data.get("format") == "bowler"


def is_spec_sheet(spec: Mapping[str, Any]) -> bool:
    """True for a bowler spec sheet (bowlers' units), False for a physical ball spec."""
    return "weight_lb" in spec


def library_lookup(balls: BallLibrary | None) -> BallLookup:
    """A :data:`BallLookup` over an archive's ball library."""

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


def parse_scene(
    data: Any, balls: BallLibrary | BallLookup | None = None, *, what: str = "scene"
) -> ParsedScene:
    """Validate a scene mapping (physical or bowler-language; library balls resolved through
    ``balls``, a library or a lookup) into the physical scene. ``what`` names the input in
    messages about its shape."""
    from pydantic import ValidationError

    from bowlrec.spec import Scene, format_validation_error

    if not isinstance(data, Mapping):
        raise SceneInputError(
            f"{what}: expected a mapping (JSON object), got {type(data).__name__}"
        )
    if "format" in data and data["format"] != "bowler":
        from bowlrec.spec.errors import printable

        raise SceneInputError(
            printable(
                "format: Input should be 'bowler' (a bowler-language scene), or left out (a "
                f"physical scene) (got {data['format']!r})"
            )
        )
    lookup = balls if callable(balls) else library_lookup(balls) if balls is not None else None
    data, ball_ref = with_library_ball(data, lookup)
    try:
        if not is_bowler(data):
            return ParsedScene(Scene.model_validate(data), ball_ref)
        from bowlrec.bowling.scene import BowlerScene

        bowler = BowlerScene.model_validate(data)
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
    try:
        return ParsedScene(bowler.to_scene(), ball_ref, bowler)
    except ValidationError as err:  # valid bowler fields whose physical scene is not
        lines = format_validation_error(err).splitlines()
        raise SceneInputError(
            "\n".join(f"{what}: the physical scene of this bowler scene: {x}" for x in lines)
        ) from None
    except ValueError as err:  # a bowler scene that cannot be placed (an illegal ball, ...)
        raise SceneInputError(f"{what}: {err}") from None


def parse_scene_file(
    path: str | Path, balls: BallLibrary | BallLookup | None = None
) -> ParsedScene:
    """Read and parse a scene file (.json, .yaml, .yml); SceneInputError prefixed with the
    path when it cannot be read or is invalid."""
    from bowlrec.spec.loading import read_mapping

    p = Path(path)
    try:
        data = read_mapping(p)
    except (OSError, ValueError) as err:
        raise SceneInputError(f"{p}: {err}") from None
    try:
        return parse_scene(data, balls)
    except SceneInputError as err:
        raise SceneInputError(prefix_lines(p, str(err))) from None
