"""The machine's FMU cache: a second folder reuses a build of the same inputs (the same bytes, no compiler run) and
says so; a change of the inputs builds anew, and says why."""

from __future__ import annotations

import dataclasses

import pytest
from tiltload.master.app.loop.fmus import build_many, loop_recipes


@pytest.fixture
def recipe():
    return next(r for r in loop_recipes() if r.fmu_name == "TiltloadScenario.fmu")


def test_a_second_folder_reuses_the_machine_s_build(recipe, tmp_path, monkeypatch):
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    said: list[str] = []
    first = build_many([recipe], tmp_path / "one", progress=said.append)[0]
    assert first.rebuilt and not first.from_cache and any(m.startswith("building TiltloadScenario.fmu") for m in said)
    said.clear()
    second = build_many([recipe], tmp_path / "two", progress=said.append)[0]
    assert second.from_cache and not second.rebuilt
    assert (tmp_path / "two" / recipe.fmu_name).read_bytes() == (tmp_path / "one" / recipe.fmu_name).read_bytes()
    assert [m for m in said if m.startswith("reusing TiltloadScenario.fmu from this machine's FMU cache")] and \
        not [m for m in said if m.startswith("building")]
    said.clear()
    changed = dataclasses.replace(recipe, identity=(*recipe.identity, "another setting"))
    third = build_many([changed], tmp_path / "two", progress=said.append)[0]
    assert third.rebuilt and not third.from_cache
    assert any("the model's settings or library versions changed" in m for m in said)
    said.clear()  # a third folder, of other inputs again: why the machine's builds are not its own
    other = dataclasses.replace(recipe, identity=(*recipe.identity, "a third setting"))
    build_many([other], tmp_path / "three", progress=said.append)
    assert any(m.startswith("building TiltloadScenario.fmu") and "this machine's FMU cache has builds of other inputs only "
               "(the model's settings or library versions changed)" in m for m in said), said


def test_a_forced_build_compiles(recipe, tmp_path, monkeypatch):
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    build_many([recipe], tmp_path / "one", progress=lambda m: None)
    again = build_many([recipe], tmp_path / "two", force=True, progress=lambda m: None)[0]
    assert again.rebuilt and not again.from_cache


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty", "a folder", "cache root a file", "cache under a file"])
def test_a_damaged_or_unusable_cache_builds_anew_and_says_so(recipe, tmp_path, monkeypatch, damage):
    """A cached copy that is not a whole FMU is built again (not named as reused) and replaced; a TILTLOAD_CACHE that
    is a file or under one costs a build, never an error."""
    import shutil

    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    first = build_many([recipe], tmp_path / "one", progress=lambda m: None)[0]
    (copy,) = (tmp_path / "cache" / "fmus").glob(f"*/{recipe.fmu_name}")
    if damage == "truncated":
        copy.write_bytes(copy.read_bytes()[:1000])
    elif damage in ("garbage", "empty"):
        copy.write_bytes(b"garbage" if damage == "garbage" else b"")
    elif damage == "a folder":
        copy.unlink()
        copy.mkdir()
    else:
        shutil.rmtree(tmp_path / "cache")
        (tmp_path / "cache").write_text("x")
        if damage == "cache under a file":
            monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache" / "sub"))
    said: list[str] = []
    again = build_many([recipe], tmp_path / "two", progress=said.append)[0]
    assert again.rebuilt and not again.from_cache and not [m for m in said if m.startswith("reusing")], said
    assert (tmp_path / "two" / recipe.fmu_name).is_file()
    if damage in ("truncated", "garbage", "empty"):  # the damaged copy is replaced by the new build
        assert copy.read_bytes() == (tmp_path / "two" / recipe.fmu_name).read_bytes()
    assert first.rebuilt
