"""The direct LZ4 path decodes exactly what Blosc decodes, and leaves every other frame to Blosc."""

import numpy as np
import pytest
from numcodecs import Blosc

from synthcal.store.blosc_lz4 import decode_into


def samples() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    flat = np.zeros((144, 256), np.uint8)
    flat[40:90, 30:200] = 3  # a semantic map: large uniform regions
    return {"compressible": flat.ravel(), "noise": rng.integers(0, 256, 110_592, dtype=np.uint8),
            "half-noise": np.concatenate([np.zeros(5000, np.uint8), rng.integers(0, 256, 5000, dtype=np.uint8)]),
            "tiny": np.arange(7, dtype=np.uint8)}


@pytest.mark.parametrize("shuffle", [Blosc.SHUFFLE, Blosc.NOSHUFFLE])
@pytest.mark.parametrize("name", ["compressible", "noise", "half-noise", "tiny"])
def test_same_bytes_as_blosc(name, shuffle):
    data = samples()[name]
    codec = Blosc(cname="lz4", clevel=5, shuffle=shuffle, typesize=1)
    frame = np.frombuffer(codec.encode(data), np.uint8).copy()
    dest = np.full(data.nbytes, 0xAB, np.uint8)
    handled = decode_into(frame.copy(), dest)
    # the store's frames (one block of ≤ 110,592 bytes) take the direct path; a frame Blosc had to
    # leave compressed-too-little is verbatim and taken too
    assert handled
    assert np.array_equal(dest, np.frombuffer(codec.decode(frame), np.uint8))


@pytest.mark.parametrize("codec", [
    Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE, typesize=4),  # shuffled 4-byte items
    Blosc(cname="lz4", clevel=5, shuffle=Blosc.BITSHUFFLE, typesize=1),
    Blosc(cname="zstd", clevel=3, shuffle=Blosc.SHUFFLE, typesize=1),
    Blosc(cname="lz4", clevel=5, shuffle=Blosc.NOSHUFFLE, typesize=1),  # several blocks (4 MiB)
], ids=["typesize-4", "bitshuffle", "zstd", "blocks"])
def test_other_frames_are_left_to_blosc(codec):
    data = np.tile(samples()["compressible"], 128)
    frame = np.frombuffer(codec.encode(data), np.uint8).copy()
    dest = np.full(data.nbytes, 0xAB, np.uint8)
    assert not decode_into(frame, dest)
    assert (dest == 0xAB).all()
