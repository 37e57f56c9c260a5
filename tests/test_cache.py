"""Disk cache: hits, atomic entries, corrupt and stale entries rebuilt (never used)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.infra import cache

RECIPE = {"kind": "test", "maxh_m": 0.1, "nested": {"a": [1, 2, 3]}}


def build_counter():
    calls = []

    def build():
        calls.append(1)
        return {"x": np.arange(10.0), "name": np.array("body")}

    return build, calls


def test_miss_then_hit(tmp_path):
    build, calls = build_counter()
    arrays, hit = cache.cached(RECIPE, build, tmp_path)
    assert not hit and len(calls) == 1
    again, hit = cache.cached(dict(RECIPE), build, tmp_path)
    assert hit and len(calls) == 1
    np.testing.assert_array_equal(again["x"], np.arange(10.0))
    assert str(again["name"]) == "body"
    # no temporary files left behind
    assert not list(tmp_path.glob("*.tmp"))


def test_different_recipe_is_a_different_entry(tmp_path):
    build, calls = build_counter()
    cache.cached(RECIPE, build, tmp_path)
    cache.cached({**RECIPE, "maxh_m": 0.05}, build, tmp_path)
    assert len(calls) == 2


def test_corrupt_data_is_rebuilt_not_used(tmp_path):
    build, calls = build_counter()
    cache.cached(RECIPE, build, tmp_path)
    key = cache.recipe_key(RECIPE)
    data = tmp_path / f"{key}.npz"
    raw = bytearray(data.read_bytes())
    raw[len(raw) // 2] ^= 0xFF  # flip bits in the middle of the archive
    data.write_bytes(bytes(raw))
    arrays, hit = cache.cached(RECIPE, build, tmp_path)
    assert not hit and len(calls) == 2
    np.testing.assert_array_equal(arrays["x"], np.arange(10.0))
    assert cache.load_entry(RECIPE, tmp_path) is not None  # the rebuilt entry is valid


def test_stale_manifest_is_rebuilt(tmp_path):
    build, calls = build_counter()
    cache.cached(RECIPE, build, tmp_path)
    key = cache.recipe_key(RECIPE)
    manifest_path = tmp_path / f"{key}.json"
    manifest = json.loads(manifest_path.read_text())
    manifest["format_version"] = -1
    manifest_path.write_text(json.dumps(manifest))
    _, hit = cache.cached(RECIPE, build, tmp_path)
    assert not hit and len(calls) == 2


def test_truncated_manifest_and_missing_data(tmp_path):
    build, calls = build_counter()
    cache.cached(RECIPE, build, tmp_path)
    key = cache.recipe_key(RECIPE)
    (tmp_path / f"{key}.json").write_text("{not json")
    assert cache.load_entry(RECIPE, tmp_path) is None
    cache.cached(RECIPE, build, tmp_path)
    (tmp_path / f"{key}.npz").unlink()
    assert cache.load_entry(RECIPE, tmp_path) is None
    assert len(calls) == 2


def test_failed_build_writes_nothing(tmp_path):
    def build():
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        cache.cached(RECIPE, build, tmp_path)
    # only the entry's (empty) lock file stays: no data, no manifest, no temporary file
    assert [p.suffix for p in tmp_path.iterdir()] == [".lock"]
    assert (tmp_path / f"{cache.recipe_key(RECIPE)}.lock").stat().st_size == 0


@pytest.mark.parametrize("manifest", ["[1, 2, 3]", "null", '"text"', "{", "\xff\xfe"])
def test_manifest_not_an_object_is_rebuilt(tmp_path, manifest):
    calls = []

    def build():
        calls.append(1)
        return {"a": np.arange(3.0)}

    key = cache.recipe_key(RECIPE)
    cache.cached(RECIPE, build, tmp_path)
    (tmp_path / f"{key}.json").write_bytes(manifest.encode("latin-1"))
    arrays, hit = cache.cached(RECIPE, build, tmp_path)
    assert not hit and len(calls) == 2 and np.array_equal(arrays["a"], np.arange(3.0))
    arrays, hit = cache.cached(RECIPE, build, tmp_path)  # the rebuilt entry is whole again
    assert hit and len(calls) == 2


def test_cache_dir_that_is_a_file_is_an_input_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InputError, match=r"--cache-dir .*file.*: a file is in the way"):
        cache.cache_dir(blocker)
    with pytest.raises(InputError, match="a file is in the way"):
        cache.cache_dir(blocker / "sub")


def _hammer(directory: str, role: str, n: int, seed: int) -> dict:
    """One process of the concurrency test: build or read one key ``n`` times; report what it saw."""
    import random
    import time

    from exudyn_study.infra import cache as c

    rng = random.Random(seed)
    expected = np.arange(200_000, dtype=float)
    seen = {"built": 0, "hits": 0, "misses": 0, "wrong": 0}

    def build():
        seen["built"] += 1
        time.sleep(rng.uniform(0, 0.02))
        return {"a": expected}

    for _ in range(n):
        if role == "builder":
            if rng.random() < 0.7:  # rewrite the valid entry with one of two valid contents: while the
                # npz and the manifest are renamed, a reader can see them out of step
                c.store_entry(RECIPE, {"a": expected * rng.choice((1.0, 2.0))}, directory)
            arrays, hit = c.cached(RECIPE, build, directory)
        else:
            arrays = c.load_entry(RECIPE, directory)
            hit = arrays is not None
        if arrays is not None and not any(np.array_equal(arrays["a"], expected * k) for k in (1.0, 2.0)):
            seen["wrong"] += 1
        seen["hits" if hit else "misses"] += 1
    return seen


def test_concurrent_builders_and_readers_of_one_key(tmp_path):
    """Four processes (2 building and rewriting, 2 reading) on one key: no crash, no wrong or lost entry."""
    import multiprocessing as mp

    import exudyn_study.infra.cache as c

    c.store_entry(RECIPE, {"a": np.arange(200_000, dtype=float)}, tmp_path)  # a valid entry to start with
    ctx = mp.get_context("spawn")
    with ctx.Pool(4) as pool:
        jobs = [pool.apply_async(_hammer, (str(tmp_path), role, 40, i))
                for i, role in enumerate(("builder", "builder", "reader", "reader"))]
        results = [j.get(timeout=300) for j in jobs]
    assert all(r["wrong"] == 0 for r in results)
    # the entry was valid all along (rewrites replace it whole): no reader missed it, no builder rebuilt it
    assert sum(r["misses"] for r in results) == 0
    assert sum(r["built"] for r in results) == 0
    assert c.load_entry(RECIPE, tmp_path) is not None
    assert not list(tmp_path.glob("*.tmp"))
