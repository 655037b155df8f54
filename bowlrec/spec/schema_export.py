"""Export the JSON Schemas of the scene models (the files under ``schemas/``)."""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import BaseModel

from .ball import Ball
from .delivery import Delivery
from .lane import Lane
from .options import Options
from .scene import Scene

__all__ = ["SCHEMA_MODELS", "export_schemas", "schema_text"]

#: file name -> model
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


def export_schemas(directory: str | Path) -> list[Path]:
    """Write every schema of :data:`SCHEMA_MODELS` into ``directory``; returns the paths."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, model in SCHEMA_MODELS.items():
        path = out / name
        path.write_text(schema_text(model), encoding="utf-8")
        paths.append(path)
    return paths
