"""Printing results: text for people, one JSON object with ``--json``."""

from __future__ import annotations

import json
import math
import sys
from typing import Any


def _jsonable(obj: Any) -> Any:
    np = sys.modules.get("numpy")  # no numpy object exists unless numpy was imported
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if np is not None and isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, float) or (np is not None and isinstance(obj, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if np is not None and isinstance(obj, np.integer):
        return int(obj)
    if np is not None and isinstance(obj, np.bool_):
        return bool(obj)
    if hasattr(obj, "model_dump"):
        return _jsonable(obj.model_dump())
    return obj


def emit(as_json: bool, text: str, obj: dict[str, Any]) -> None:
    """Print ``text`` for people, or ``obj`` as one JSON object when ``as_json``."""
    if as_json:
        sys.stdout.write(json.dumps(_jsonable(obj)) + "\n")
    else:
        sys.stdout.write(text.rstrip("\n") + "\n")
    sys.stdout.flush()
