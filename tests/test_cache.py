"""Disk cache: hits, atomic entries, corrupt and stale entries rebuilt (never used)."""

from __future__ import annotations

import json

import numpy as np

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

    try:
        cache.cached(RECIPE, build, tmp_path)
    except RuntimeError:
        pass
    assert list(tmp_path.iterdir()) == []
