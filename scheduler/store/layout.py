"""The store's layout on disk, declared once: the attrs that say how it was written, the
folders beside its arrays, and the reading of its root attrs (what every other module of the
store derives its paths and checks from). The variables, their dims and chunks are
study.schema's (VARIABLES, template); this module says how they are laid out in files."""
from __future__ import annotations

import contextlib
import json
import warnings
from pathlib import Path
from typing import Any

from hertzmap.scheduler.errors import StoreError
from hertzmap.study.schema import StoreFormatError, check_format

ALL_CHUNKS_ATTR = "hertzmap_all_chunks_written"
#: the atlas's progress (its round and phase: scheduler.atlas_tasks)
ATLAS_ATTR = "hertzmap_atlas"
#: the most entries any point of the store holds along each slot dim so far (study.schema
#: SLOT_DIMS), kept by the client as blocks and atlas rounds are written: the length the dims
#: are cut to when the run ends (Store.settle_slots)
SLOTS_USED_ATTR = "hertzmap_slots_used"


@contextlib.contextmanager
def quiet():
    # zarr warns that consolidated metadata is not part of the v3 spec; we use it on purpose
    # so that xr.open_zarr(path) opens the store quickly and silently.
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Cc]onsolidated metadata.*")
        # the traced curves' parts folder (CURVE_PARTS) and the stages' staging folders
        # (ATLAS_STAGE, SWEEP_STAGE) are not zarr nodes of the store
        warnings.filterwarnings("ignore", message=".*not recognized as a component of a Zarr")
        yield


def read_attrs(path: str | Path) -> dict[str, Any] | None:
    """Root attrs of a zarr store, or None when ``path`` is not a zarr (v3) group."""
    meta = Path(path) / "zarr.json"
    if not meta.is_file():
        return None
    try:
        doc = json.loads(meta.read_text())
    except (OSError, ValueError):
        return None
    if doc.get("node_type") != "group":
        return None
    return doc.get("attributes", {})


def store_attrs(path: str | Path) -> dict[str, Any]:
    """Root attrs of a store this version reads: StoreError when ``path`` is not a zarr store
    or holds another layout (study.schema.check_format's message: its format, what to do)."""
    attrs = read_attrs(path)
    if attrs is None:
        raise StoreError(f"{path} is not a zarr store")
    try:
        check_format(attrs, str(path))
    except StoreFormatError as exc:
        raise StoreError(str(exc)) from None
    return attrs


def block_name(index) -> str:
    """The name of a block's (or a tile's) staged file: its index, ``i-j-k``."""
    return "-".join(str(int(i)) for i in index)
