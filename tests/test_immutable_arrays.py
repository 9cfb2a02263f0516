"""Immutable (bytes-backed) arrays: their content cannot change, so kernels reuse checks and uploads of them
by identity (kernels/_arrays.py); the loaded avatar's arrays are made this way."""
import numpy as np
import pytest

from kernels._arrays import UploadCache, immutable, is_immutable
from media.avatar import load_avatar


def test_an_immutable_array_keeps_its_values_and_cannot_be_made_writeable():
    source = np.arange(12, dtype=np.int32).reshape(4, 3)
    frozen = immutable(source)
    assert frozen.dtype == source.dtype and frozen.shape == source.shape and np.array_equal(frozen, source)
    source[0, 0] = 99                                    # the copy does not follow its source
    assert frozen[0, 0] == 0
    with pytest.raises(ValueError):
        frozen.flags.writeable = True
    with pytest.raises(ValueError):
        frozen[1:].flags.writeable = True
    assert is_immutable(frozen) and is_immutable(frozen[1:]) and is_immutable(frozen.T)
    for other in (np.float32(3.5), np.zeros((0, 3), np.int32), np.arange(6.0).reshape(2, 3).T):
        copy = immutable(other)                           # a scalar, an empty array, a transposed view
        assert copy.shape == np.shape(other) and copy.dtype == np.asarray(other).dtype
        assert np.array_equal(copy, other) and copy.flags.c_contiguous and is_immutable(copy)


def test_read_only_views_of_writeable_memory_are_not_immutable():
    source = np.zeros(5)
    view = source[1:]
    view.flags.writeable = False
    assert not is_immutable(source) and not is_immutable(view)
    owner = np.zeros(5)
    owner.flags.writeable = False                         # its owner may set it writeable again
    assert not is_immutable(owner)


def test_the_upload_cache_takes_no_snapshot_of_an_immutable_input_and_one_of_a_writeable_one():
    uploads = []
    cache = UploadCache(lambda a: uploads.append(a.copy()) or len(uploads))
    frozen, plain = immutable(np.arange(4.0)), np.arange(4.0)
    assert cache.get("a", frozen) == cache.get("a", frozen) == 1
    assert cache.get("b", plain) == cache.get("b", plain) == 2
    plain[0] = 7.0                                       # changed in place: uploaded again
    assert cache.get("b", plain) == 3 and uploads[-1][0] == 7.0
    snapshots = {key[0]: entry[1] for key, entry in cache._entries.items()}
    assert snapshots["a"] is None and snapshots["b"] is not None


def test_the_loaded_avatar_is_immutable():
    avatar = load_avatar()
    arrays = [avatar.vertices, avatar.triangles, avatar.triangle_part, avatar.triangle_shape,
              avatar.weights.indptr, avatar.weights.bones, avatar.weights.values,
              avatar.skeleton.parents, avatar.skeleton.heads, avatar.skeleton.tails]
    assert all(is_immutable(a) for a in arrays)
