"""The zarr store of a study: every write into a store and every lock of hertzmap is in this
package, one concern per module (docs/architecture.md, "The store"):

* ``layout``: the attrs, folders and shard shapes of a store, declared once (from study.schema);
* ``lock``: one client per store (``Lock``) and a worker's check that its client holds it;
* ``commit_flags``: the ``task_done`` flags, set by the client once a block is in the store;
* ``block_writes``: a block of every variable written into the main group (``BlockWriter``);
* ``staging``: the one way a result reaches the client (one file, whole or not at all): the
  grid's blocks, the atlas's tiles, the sweeps, the traced curves;
* ``slot_dims``: the slot dims grown and cut by the client;
* ``region_reads``: a region of the main group read (the atlas);
* ``store_handle``: ``Store``, the store opened by its client, and ``open_or_create``;
* ``store_status``: ``hertzmap status``; ``product_groups``: the products groups.

The names other modules use are imported here.
"""
from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store.block_writes import (SHARD_LOG_ENV, BlockWriter, pack_shard,
                                                   stage_task_block, staged_blocks)
from hertzmap.scheduler.store.commit_flags import read_done_flags
from hertzmap.scheduler.store.layout import (ALL_CHUNKS_ATTR, ATLAS_ATTR, SHARD_BLOCKS_ATTR,
                                             SHARD_POINTS, SLOTS_USED_ATTR, block_name,
                                             read_attrs, shard_blocks, store_attrs)
from hertzmap.scheduler.store.lock import (LOCK_SUFFIX, Lock, check_writer, lock_path,
                                           shared_store_hint)
from hertzmap.scheduler.store.product_groups import (TRACED_CURVES, finish_traced_curves,
                                                     has_run_product, list_products, read_product,
                                                     write_product, write_products)
from hertzmap.scheduler.store.region_reads import read_region
from hertzmap.scheduler.store.slot_dims import slots_used
from hertzmap.scheduler.store.staging import (ATLAS_STAGE, CURVE_PARTS, GRID_STAGE, SWEEP_STAGE,
                                              SWEPT_STAGE, read_atlas_tile, read_curve_parts,
                                              read_stage_file, remove_atlas_stage, remove_stage,
                                              stage_atlas_tile, stage_file, stage_sweep,
                                              stage_swept, staged_atlas_tiles, staged_files,
                                              staged_sweeps, staged_swept, sweep_name, swept_name,
                                              write_atlas_tile, write_curve_part)
from hertzmap.scheduler.store.store_handle import Store, open_or_create, remove_store
from hertzmap.scheduler.store.store_status import store_contents, store_status
from hertzmap.study.schema import PRODUCT_GROUP
