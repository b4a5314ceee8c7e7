"""Decoding the store's Blosc-LZ4 chunks without Blosc's per-call set-up, same bytes out.

Every ``image`` and ``semantic`` chunk is one sample compressed by Blosc 1 with LZ4,
``typesize`` 1, as a single block. ``numcodecs.Blosc.decode`` builds a fresh Blosc
context with its scratch buffers for every call (Zarr turns Blosc's global context
off for thread safety): ≈ 14 µs of a semantic map's ≈ 9 µs of actual LZ4 work, and
a third of ``load_split``'s decoding time (``benchmarks/README.md``). A single-block
frame of that shape is a 16-byte header, one block offset and the block as one LZ4
stream, so it is decoded here with LZ4 directly; any other frame (several blocks,
shuffled ``typesize`` > 1, bitshuffle, another compressor) returns False and the
caller passes it to Blosc, so the output never depends on the path (the tests
compare both on compressible, incompressible and other-shaped frames).

Blosc 1 frame, as read here (little endian): byte 0 format version (2), byte 1 the
compressor's format version, byte 2 flags (``0x01`` byte shuffle, ``0x02`` stored
verbatim, ``0x04`` bitshuffle, ``0x10`` streams not split, bits 5–7 the compressor:
1 is LZ4), byte 3 ``typesize``, bytes 4–7 ``nbytes``, 8–11 ``blocksize``, 12–15
``cbytes`` (the frame's length); then one int32 start offset per block; at a block's
start, per stream, an int32 compressed length and the stream (a stream as long as
its block is stored verbatim).
"""

from __future__ import annotations

import numpy as np
from numcodecs import lz4

__all__ = ["decode_into"]

_HEADER = 16
_VERBATIM, _BITSHUFFLE, _FLAG_BITS = 0x02, 0x04, 0x1F
_LZ4 = 1
# Flags that leave a typesize-1, single-block frame one plain stream: byte shuffle of 1-byte items
# is the identity, and with one item size there is nothing to split.
_PLAIN = {0x00, 0x01, 0x10, 0x11}


def decode_into(frame: np.ndarray, dest: np.ndarray) -> bool:
    """Decode a single-block, ``typesize`` 1 Blosc-LZ4 frame into ``dest``; False for any other frame.

    Args:
        frame: (L,) uint8, the whole frame; **writable**: the 4 bytes before the LZ4
            stream are overwritten with its decoded length, the header LZ4's decoder
            reads (the caller's buffer, checked by CRC32C before and discarded after).
        dest: (nbytes,) uint8, contiguous: the decoded chunk.

    Returns:
        True when ``dest`` holds the decoded chunk; False (``dest`` untouched) for a
        frame of another shape, left to ``numcodecs.Blosc``.

    Raises:
        RuntimeError: LZ4 found the stream damaged.
    """
    if len(frame) < _HEADER:
        return False
    header = frame[:_HEADER].view("<u4")
    flags, typesize = int(frame[2]), int(frame[3])
    nbytes, blocksize, cbytes = int(header[1]), int(header[2]), int(header[3])
    if frame[0] != 2 or typesize != 1 or nbytes != dest.nbytes or cbytes != len(frame):
        return False
    if flags & _VERBATIM:
        if flags & _BITSHUFFLE or cbytes != _HEADER + nbytes:
            return False
        dest[:] = frame[_HEADER:]
        return True
    if cbytes < _HEADER + 8:
        return False
    start, stream = (int(v) for v in frame[_HEADER:_HEADER + 8].view("<u4"))
    if flags >> 5 != _LZ4 or flags & _FLAG_BITS not in _PLAIN or blocksize != nbytes or start != _HEADER + 4 \
            or stream != cbytes - start - 4:
        return False
    if stream == nbytes:  # the block did not compress: Blosc kept it verbatim
        dest[:] = frame[start + 4:]
        return True
    frame[start:start + 4] = np.frombuffer(nbytes.to_bytes(4, "little"), np.uint8)
    lz4.decompress(frame[start:], dest)
    return True
