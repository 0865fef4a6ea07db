"""Source manifest and lookup: local root, cache, file:// mirror downloads, hash checks, offline errors (no network)."""

import shutil

import pytest

from loco_mujoco.datasets.sources import fetch
from loco_mujoco.datasets.sources.fetch import (
    SOURCE_FILES,
    SourceHashError,
    default_sources_root,
    sha256_of,
    source_path,
)

ROOT = default_sources_root()
SMALL = ("loco-mujoco-format/LICENSE", "noncommercial/dog-keypoints/dog_clips_info.txt")


def shared_root():
    if ROOT is None:
        pytest.skip("shared motion sources not found (set LOCO_MUJOCO_SOURCES)")
    return ROOT


@pytest.fixture
def isolated(tmp_path, monkeypatch):
    """An empty sources root and an empty cache; no mirror."""
    (tmp_path / "empty_root").mkdir()
    monkeypatch.setenv("LOCO_MUJOCO_SOURCES", str(tmp_path / "empty_root"))
    monkeypatch.setenv("LOCO_MUJOCO_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("LOCO_MUJOCO_MIRROR", raising=False)
    return tmp_path


def _mirror(tmp_path, monkeypatch, corrupt=False):
    mirror = tmp_path / "mirror"
    for rel in SMALL:
        (mirror / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(shared_root() / rel, mirror / rel)
        if corrupt:
            with open(mirror / rel, "ab") as handle:
                handle.write(b"tampered")
    monkeypatch.setenv("LOCO_MUJOCO_MIRROR", mirror.as_uri())


def test_manifest_covers_shared_folder():
    root = shared_root()
    local = {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file() and p.name != "SOURCES.md"}
    assert local == set(SOURCE_FILES)
    for rel, entry in SOURCE_FILES.items():
        assert sha256_of(root / rel) == entry.sha256, rel
        assert entry.url.startswith("https://raw.githubusercontent.com/")
        assert entry.commercial_use == (not rel.startswith("noncommercial/"))
        assert entry.licence in ("MIT", "Apache-2.0", "CMU-free (no resale)", "CC-BY-NC-4.0")


def test_local_root_and_verify():
    path = source_path("cmu/07_02.bvh", verify=True)
    assert path == shared_root() / "cmu/07_02.bvh"


def test_unknown_relpath_suggests():
    with pytest.raises(KeyError, match="cmu/07_02.bvh"):
        source_path("cmu/07_2.bvh")


def test_env_root(tmp_path, monkeypatch):
    monkeypatch.setenv("LOCO_MUJOCO_SOURCES", str(tmp_path))
    assert default_sources_root() == tmp_path
    monkeypatch.setenv("LOCO_MUJOCO_SOURCES", str(tmp_path / "missing"))
    with pytest.raises(FileNotFoundError, match="LOCO_MUJOCO_SOURCES"):
        default_sources_root()


def test_mirror_download_then_cache(isolated, monkeypatch):
    _mirror(isolated, monkeypatch)
    for rel in SMALL:
        path = source_path(rel)
        assert path == isolated / "cache" / "sources" / rel
        assert sha256_of(path) == SOURCE_FILES[rel].sha256
        assert path.stat().st_mode & 0o777 == 0o644  # readable by every user of a shared cache
    assert not [p for p in (isolated / "cache").rglob(".*") if p.is_file()]  # no temporaries left behind
    monkeypatch.delenv("LOCO_MUJOCO_MIRROR")
    shutil.rmtree(isolated / "mirror")
    assert source_path(SMALL[0], allow_download=False, verify=True) == isolated / "cache" / "sources" / SMALL[0]


def test_corrupted_mirror(isolated, monkeypatch):
    _mirror(isolated, monkeypatch, corrupt=True)
    with pytest.raises(SourceHashError) as err:
        source_path(SMALL[0])
    message = str(err.value)
    assert SMALL[0] in message and SOURCE_FILES[SMALL[0]].sha256 in message
    assert sha256_of(isolated / "mirror" / SMALL[0]) in message
    cache = isolated / "cache"
    assert not cache.exists() or not [p for p in cache.rglob("*") if p.is_file()]


def test_corrupted_cache_is_dropped_on_verify(isolated):
    cached = fetch.cache_dir() / "sources" / SMALL[0]
    cached.parent.mkdir(parents=True)
    cached.write_text("not the licence")
    assert source_path(SMALL[0], allow_download=False) == cached  # verification is on demand
    with pytest.raises(SourceHashError):
        source_path(SMALL[0], allow_download=False, verify=True)
    assert not cached.exists()


def test_offline_error(isolated):
    with pytest.raises(FileNotFoundError) as err:
        source_path("cmu/07_02.bvh", allow_download=False)
    assert "LOCO_MUJOCO_SOURCES" in str(err.value) and "allow_download=True" in str(err.value)
