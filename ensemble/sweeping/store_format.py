"""What every hertzian Zarr v3 store shares: schema version, chunk codecs (zstd, then a CRC-32C checksum of the
compressed bytes), consolidated metadata, and the errors a store raises when its bytes are damaged.

Both the writer (``hertzian.sweeping.sweep_store``) and the reader (``hertzian.sweeping.store``) import this
module; neither imports the other.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import zarr
import zarr.codecs

SCHEMA_VERSION = 1
"""Version of the store layout (docs/model.md §6); chunk checksums are a codec, read from each array's metadata, and
change nothing a reader must know."""
RESULT_ZSTD_LEVEL = 1
"""zstd level of the per-point result arrays: simulated floats barely compress at any level, and level 1 encodes
them faster than the default level 3; the last batch's write is the sweep's tail, which nothing overlaps."""
CHECKSUM_CODEC = "crc32c"
"""Name (in an array's ``zarr.json``) of the codec that appends a CRC-32C of each chunk's compressed bytes."""


DAMAGED_EXIT_CODE = 1
"""Exit code of ``hertzian verify`` and ``hertzian summarize`` for a store with a damaged chunk."""


class StoreDamagedError(ValueError):
    """A chunk whose bytes no longer match their checksum (or no longer decode). The message is one line that
    names the store, the variable and what to do."""


def chunk_codecs(level: int = RESULT_ZSTD_LEVEL) -> tuple:
    """Compressors of every array: zstd at ``level``, then a CRC-32C checksum (verified by zarr on every read).
    In a sharded array they apply to each inner chunk; the shard index carries its own CRC-32C (zarr's default)."""
    return (zarr.codecs.ZstdCodec(level=level), zarr.codecs.Crc32cCodec())


def has_checksums(array) -> bool:
    """Whether a zarr array's chunks (inner chunks when sharded) carry a CRC-32C."""
    codecs = array.metadata.to_dict().get("codecs", [])
    for codec in codecs:
        if codec.get("name") == "sharding_indexed":
            codecs = codec.get("configuration", {}).get("codecs", [])
            break
    return any(codec.get("name") == CHECKSUM_CODEC for codec in codecs)


DAMAGE_ERRORS = (ValueError, RuntimeError)
"""What zarr raises reading a damaged chunk: ``ValueError`` for a checksum mismatch (and, in a store without
checksums, for bytes that no longer decode: a corrupt buffer, bad UTF-8), ``RuntimeError`` for a zstd frame that
no longer decompresses."""


def consolidate(path: str | Path) -> None:
    """Consolidated metadata (zarr warns that v3 has no spec for it yet; xarray uses it)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)
        zarr.consolidate_metadata(str(path))


def package_version() -> str:
    """This package's version (``hertzian._version``: the same installed or run from a source tree)."""
    from hertzian._version import __version__

    return __version__
