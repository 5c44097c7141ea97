"""The kernel's libraries are built on first use into the cache; threads and processes that ask at once all get a
whole library (the CI once loaded a half-written tl_loop.so from the log writer's thread)."""
import ctypes
import subprocess

from support.at_once import at_once
from tiltload.master.engine.native import kernel

SOURCE = '__attribute__((visibility("default"))) int tl_answer(void) { return 42; }\n'


def test_threads_asking_for_one_new_library_at_once_all_load_it(tmp_path, monkeypatch):
    c = tmp_path / "answer.c"
    c.write_text(SOURCE)
    for attempt in range(6):  # the race, when there is one, is met in about one attempt in five
        cache = tmp_path / f"cache{attempt}"
        monkeypatch.setenv("TILTLOAD_CACHE", str(cache))
        _all_threads_load_it(c, cache)


def _all_threads_load_it(c, cache):
    def ask():
        lib = kernel.compiled("answer", (c,))
        lib.tl_answer.restype = ctypes.c_int
        return lib.tl_answer()

    results, errors = at_once(ask)
    assert errors == [] and results == [42] * 8
    built = list((cache / "kernels").rglob("*"))
    assert [p.name for p in built if p.is_file()] == ["answer.so"]  # no partial file left behind


def test_the_same_sources_in_another_temporary_folder_are_the_same_library(tmp_path, monkeypatch):
    """Generated code written to a new temporary folder in every process (the feasibility check's trim library) is built
    once per machine: an include folder of a listed source counts by its files' content, not its path."""
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))

    def build(folder, header):
        folder.mkdir()
        (folder / "answer.h").write_text(header)
        (folder / "answer.c").write_text('#include "answer.h"\n' + SOURCE.replace("42", "ANSWER"))
        lib = kernel.compiled("answer", (folder / "answer.c", folder / "answer.h"), (*kernel.CFLAGS, f"-I{folder}"))
        lib.tl_answer.restype = ctypes.c_int
        return lib.tl_answer()

    assert build(tmp_path / "one", "#define ANSWER 42\n") == 42 and build(tmp_path / "two", "#define ANSWER 42\n") == 42
    assert len(list((tmp_path / "cache" / "kernels").iterdir())) == 1
    assert build(tmp_path / "three", "#define ANSWER 7\n") == 7  # another header: another library
    assert len(list((tmp_path / "cache" / "kernels").iterdir())) == 2


def test_a_numpy_random_library_that_does_not_link_leaves_the_draws_to_numpy(tmp_path, monkeypatch):
    """An archive the linker refuses: the kernel is built without the C draws (noise and jitter then drawn by numpy
    in Python), not lost."""
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    broken = tmp_path / "libnpyrandom.a"
    broken.write_bytes(b"!<arch>\nnot an archive member")
    include = kernel._numpy_random()[1] if kernel._numpy_random() else tmp_path
    monkeypatch.setattr(kernel, "_numpy_random", lambda: (broken, include))
    assert kernel._with_draws() is None
    lib = kernel.compiled("tl_loop", kernel.SOURCES, libraries=("m",))  # what library() builds instead
    assert hasattr(lib, "tl_run") and not hasattr(lib, "tl_draw_normal")


def test_the_tick_loop_compiles_as_c99_with_every_warning_an_error():
    """tl_loop.c (the clocked FMUs' Event Mode included), tl_mcap.c, tl_layout.c and the isolated FMU's host loop
    (isolation/c/tl_host.c): C99, -pedantic -Wall -Wextra -Wshadow, and -Wmissing-prototypes (an exported function is
    declared first, any other is static)."""
    from tiltload.master.engine.isolation import link

    for source in (kernel.HERE / "tl_loop.c", kernel.HERE / "tl_mcap.c", kernel.HERE / "tl_layout.c", link.HOST[0]):
        proc = subprocess.run(["cc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Wshadow", "-Wmissing-prototypes", "-Werror",
                               "-O2", "-fsyntax-only", f"-I{kernel.HERE}", str(source)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
