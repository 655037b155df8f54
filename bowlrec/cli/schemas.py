"""The JSON Schemas of bowlrec's input files (the files under ``schemas/``).

``SCHEMAS`` names each schema and the function that returns its canonical text: the physical
scene and its parts (:mod:`bowlrec.spec`), the bowler-language scene (``"format": "bowler"``,
:mod:`bowlrec.bowling.scene`) and the batch job (``"format": "bowlrec-job"``,
:mod:`bowlrec.batch.job_spec`). ``bowlrec schema NAME`` prints one; ``bowlrec schema --out
DIR`` writes them all as ``DIR/NAME.schema.json``. The schemas span the scene, bowler and batch
layers, so they are gathered here, on the command line's floor.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel

from bowlrec.spec import Ball, Delivery, Lane, Options, Scene

__all__ = ["SCHEMAS", "SCHEMA_MODELS", "export_schemas", "schema_file", "schema_text"]

#: file name -> model of the physical scene and its parts
SCHEMA_MODELS: dict[str, type[BaseModel]] = {
    "scene.schema.json": Scene,
    "ball.schema.json": Ball,
    "lane.schema.json": Lane,
    "delivery.schema.json": Delivery,
    "options.schema.json": Options,
}


def schema_text(model: type[BaseModel]) -> str:
    """Canonical text of a model's JSON Schema: indent 2, sorted keys, trailing newline."""
    return json.dumps(model.model_json_schema(), indent=2, sort_keys=True) + "\n"


def _bowler_scene_text() -> str:
    from bowlrec.bowling.scene import BowlerScene

    return schema_text(BowlerScene)


def _job_text() -> str:
    from bowlrec.batch.job_spec import job_schema_text

    return job_schema_text()


def _model_text(model: type[BaseModel]) -> Callable[[], str]:
    return lambda: schema_text(model)


#: schema name -> its canonical text (the file is ``NAME.schema.json``)
SCHEMAS: dict[str, Callable[[], str]] = {
    **{name.removesuffix(".schema.json"): _model_text(m) for name, m in SCHEMA_MODELS.items()},
    "bowler-scene": _bowler_scene_text,
    "job": _job_text,
}


def schema_file(name: str) -> str:
    """The file name schema ``name`` is written to."""
    return f"{name}.schema.json"


def export_schemas(directory: str | Path, names: list[str] | None = None) -> list[Path]:
    """Write the schemas ``names`` (default: all of :data:`SCHEMAS`) into ``directory``;
    returns the paths."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in names or list(SCHEMAS):
        path = out / schema_file(name)
        path.write_text(SCHEMAS[name](), encoding="utf-8")
        paths.append(path)
    return paths
