"""The user's class code, run where it cannot end or stall tiltload: a child process of its own (its own session,
TMPDIR and address-space limit), watched by a timer here. Importing the file, `__init__`, the trace of `step` and
pythonfmu's packaging (which imports the file again) run there; what comes back is data: the class's description,
the traced function (CasADi's serialized text) and its numbers, or one line saying why not. `sys.exit()`, a loop
without end, a long call into C, `os.chdir`, a crash of the interpreter: each ends the child, never tiltload.

The child reports each part of the user's code as it starts (trace.time_limit's WATCH): the watchdog gives that part
TIME_LIMIT_S (and a few seconds for the child's own timer to say it first), tiltload's own work in the child
OWN_LIMIT_S."""

from __future__ import annotations

import json
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MEMORY_LIMIT = 4 << 30  # bytes of address space: numpy, CasADi and a controller's arrays fit many times over
START_LIMIT_S = 120.0  # the child's own imports (numpy, CasADi) on a loaded machine
OWN_LIMIT_S = 300.0  # tiltload's work in the child between the user's parts: the trim, CasADi's function, pythonfmu
GRACE_S = 5.0  # past a part's limit before the watchdog cuts: the child's own timer names the line when it can


def _limit_s() -> float:
    from . import trace

    return trace.TIME_LIMIT_S  # read when called: a test shortens it


def _error(kind: str, message: str) -> Exception:
    from .trace import InitError, TraceError
    from .wrap import WrapError

    return {"InitError": InitError, "TraceError": TraceError}.get(kind, WrapError)(message)


def _run(job: str, path: Path, use=lambda result: result, **args):
    """Run job in a child on the user's file; use(its result) (a dict, before its folder goes), or its refusal raised
    as WrapError and kin."""
    from ...engine.user_files import open_binary

    with open_binary(path, "controller"):  # the file this process was handed opens here, as every input file does: what
        pass  # it is instead (a FIFO, a folder, behind a permission) is this one line, not the child's
    work = Path(tempfile.mkdtemp(prefix="tiltload_wrap_"))
    (work / "tmp").mkdir()
    request = {"job": job, "path": str(path), "limit": _limit_s(), "work": str(work), "sys_path": sys.path, **args}
    env = {**os.environ, "TMPDIR": str(work / "tmp")}
    proc = subprocess.Popen([sys.executable, "-m", __name__, json.dumps(request)], stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, env=env, start_new_session=True)
    try:
        return use(_watch(proc, path))
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # the child, and whatever the user's code started in its session
        except (ProcessLookupError, PermissionError):
            pass
        proc.wait()
        proc.stdout.close()
        shutil.rmtree(work, ignore_errors=True)


def _watch(proc: subprocess.Popen, path: Path) -> dict:
    """Read the child's reports until its last line; cut it at a part's time limit."""
    fd, buffer, last = proc.stdout.fileno(), b"", None
    what, limit = "starting", START_LIMIT_S
    deadline = time.monotonic() + limit
    while True:
        ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        if not ready:
            kind = "InitError" if what.endswith("()") else "TraceError" if what.endswith(".step") else "WrapError"
            if what in ("starting", "tiltload's own work"):
                raise RuntimeError(f"wrap's child process: {what} took over {limit:g} s")
            raise _error(kind, f"{what} did not return within {_limit_s():g} s (a loop without end, or a long call "
                               "into C?)")
        chunk = os.read(fd, 1 << 16)
        if not chunk:
            break
        buffer += chunk
        *lines, buffer = buffer.split(b"\n")
        for line in lines:
            try:
                message = json.loads(line)
                message.get("part")
            except (ValueError, AttributeError):  # the user's code wrote into the reports (it has their descriptor)
                raise _error("WrapError", f"{path.name}: the class's code wrote into the channel tiltload reads its "
                                          f"results from, while {what}") from None
            if "part" in message:
                what, limit = (message["part"], message["limit"] + GRACE_S) if message["part"] else (
                    "tiltload's own work", OWN_LIMIT_S)
                deadline = time.monotonic() + limit
            else:
                last = message
    code = proc.wait()
    if last is None:
        how = f"signal {signal.Signals(-code).name}" if code < 0 else f"exit status {code}"
        raise _error("InitError" if what.endswith("()") else "WrapError",
                     f"{path.name}: the class's code ended the process that ran it ({how}) while "
                     f"{'importing the file' if what == 'starting' else what}")
    if "error" in last:
        raise _error(last["kind"], last["error"])
    if "bug" in last:
        raise RuntimeError(f"wrap's child process: {last['bug']}")
    return last["result"]


def traced(path: Path, class_name: str | None, fall_back: bool = False):
    """(spec, Traced) of the class; with fall_back, (spec, why) when its step cannot be traced (its __init__ ran)."""
    import casadi as ca

    from .trace import Traced

    result = _run("trace", Path(path).resolve(), class_name=class_name, fall_back=fall_back)
    t = result["traced"]
    if isinstance(t, str):
        return result["spec"], t
    return result["spec"], Traced(ca.Function.deserialize(t["function"]), t["inputs"],
                                  [tuple(p) for p in t["parameters"]], [tuple(s) for s in t["states"]],
                                  ca.Function.deserialize(t["init"]), t["fixed"], t["why_fixed"])


def wrap_python(path: Path, out: Path | None = None, class_name: str | None = None) -> Path:
    """`tiltload wrap`: the pythonfmu FMU of the class (default: next to the file, <stem>.fmu); its __init__ is run
    once first, so one that raises is refused now, not in a run."""
    from .wrap import WrapError

    target = Path(out) if out else Path(path).with_suffix(".fmu")
    path = Path(path).resolve()
    if target.suffix != ".fmu":
        raise WrapError(f"the output {target} must end in .fmu")

    def move(result: dict) -> None:
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(result["fmu"], target)

    _run("package", path, use=move, class_name=class_name, name=target.name)
    return target


# ---- the child ------------------------------------------------------------------------------------------------------

def _job(request: dict) -> dict:
    from . import trace, wrap

    path, limit = Path(request["path"]), request["limit"]
    trace.TIME_LIMIT_S = limit
    with trace.time_limit(f"importing {path.name}", wrap.WrapError):
        module = wrap.load_module(path)
    name, cls = wrap.find_class(module, path, request["class_name"])
    spec = wrap.describe_class(cls, path)
    if request["job"] == "describe":
        return spec
    if request["job"] == "package":
        trace.step_once(trace.instantiate(cls, spec["parameters"], path), spec, path)
        target = Path(request["work"]) / "out" / request["name"]
        return {"spec": spec, "fmu": str(wrap.package(path, spec, target))}
    try:
        t = trace.trace(cls, spec["parameters"], list(spec["inputs"]), path)
    except trace.InitError:
        raise
    except trace.TraceError as err:
        if not request["fall_back"]:
            raise
        return {"spec": spec, "traced": str(err)}
    return {"spec": spec, "traced": {"function": t.function.serialize(), "inputs": t.inputs,
                                     "parameters": t.parameters, "states": t.states, "init": t.init.serialize(),
                                     "fixed": t.fixed, "why_fixed": t.why_fixed}}


def _child(request: dict) -> None:
    import resource

    from . import trace

    report = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # the user's prints go to stderr; stdout carries the reports
    # the caller's folders after the child's own: the user's file may import its neighbours as it did there, but a
    # folder the caller added (a pinned pythonfmu FMU's resources, which bundle a pythonfmu without its binaries)
    # shadows no package of tiltload's
    sys.path.extend(p for p in request["sys_path"] if p not in sys.path)
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    trace.WATCH = lambda what, seconds: report.write(json.dumps({"part": what, "limit": seconds}) + "\n")
    trace.WATCH("", 0.0)
    try:
        out = {"result": _job(request)}
    except trace.TraceError as err:
        out = {"error": str(err), "kind": type(err).__name__}
    except Exception as err:  # WrapError; a MemoryError of ours at the limit; else a bug of ours, said as such
        from .wrap import WrapError

        if isinstance(err, (WrapError, MemoryError)):
            text = str(err) if isinstance(err, WrapError) else f"out of memory (the limit is {MEMORY_LIMIT >> 30} GiB)"
            out = {"error": text, "kind": "WrapError"}
        else:
            out = {"bug": f"{type(err).__name__}: {err}"}
    except BaseException as err:  # SystemExit where none of the user's parts caught it (a class attribute's code)
        out = {"error": f"{Path(request['path']).name}: the class's code raised {type(err).__name__}", "kind": "WrapError"}
    report.write(json.dumps(out) + "\n")
    report.flush()
    sys.stderr.flush()
    os._exit(0)  # no atexit of the user's code runs


if __name__ == "__main__":
    _child(json.loads(sys.argv[1]))
