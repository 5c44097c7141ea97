"""System descriptions and connections: every problem is named before the first step."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from types import SimpleNamespace

import pytest
from tiltload.master.app.cli import main
from tiltload.master.engine.connections import resolve
from tiltload.master.engine.errors import DescriptionError
from tiltload.master.engine.system import Connection, Instance, System


def test_non_fmu_and_model_exchange_only_are_refused(fmus, tmp_path, capsys):
    text = tmp_path / "notes.fmu"
    text.write_text("not a zip")
    assert main(["run", "--controller", str(text), "--fmus", str(fmus), "--out", str(tmp_path)]) == 2
    assert "not an FMU" in capsys.readouterr().err
    me = tmp_path / "me_only.fmu"
    with zipfile.ZipFile(fmus / "TiltloadScenario.fmu") as src, zipfile.ZipFile(me, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = data.decode().replace("<CoSimulation", "<ModelExchange").replace("</CoSimulation", "</ModelExchange").encode()
            dst.writestr(item, data)
    assert main(["run", "--controller", str(me), "--fmus", str(fmus), "--out", str(tmp_path)]) == 2
    assert "model-exchange-only" in capsys.readouterr().err


def fake_md(name, variables):
    return SimpleNamespace(modelName=name, modelVariables=[SimpleNamespace(name=n, causality=c, type=t, start=s, valueReference=i)
                                                            for i, (n, c, t, s) in enumerate(variables)])


def test_connection_problems_are_named():
    a = fake_md("A", [("u", "output", "Real", 0.0), ("flag", "output", "Boolean", False)])
    b = fake_md("B", [("u", "output", "Real", 0.0)])
    c = fake_md("C", [("u", "input", "Real", 0.0), ("w", "input", "Real", None), ("p", "parameter", "Real", 1.0)])
    inst = lambda *names: [Instance(n, Path(f"{n}.fmu")) for n in names]  # noqa: E731
    with pytest.raises(DescriptionError, match="C.u: ambiguous, outputs of that name in A, B"):
        resolve(System(0.012, inst("A", "B", "C")), {"A": a, "B": b, "C": c})
    with pytest.raises(DescriptionError, match="C.w is an input with no connection and no start value"):
        resolve(System(0.012, inst("A", "C"), [Connection("A.u", "C.u")]), {"A": a, "C": c})
    with pytest.raises(DescriptionError, match="A.flag -> C.w: Boolean -> Float64 would lose values"):
        resolve(System(0.012, inst("A", "C"), [Connection("A.flag", "C.w")]), {"A": a, "C": c})
    with pytest.raises(DescriptionError, match="C.p is a parameter, not an input"):
        resolve(System(0.012, inst("A", "C"), [Connection("A.u", "C.p")]), {"A": a, "C": c})
    with pytest.raises(DescriptionError, match="A has no variable 'v'"):
        resolve(System(0.012, inst("A", "C"), [Connection("A.v", "C.w")]), {"A": a, "C": c})


def test_bad_system_description_files(tmp_path, capsys):
    assert main(["run", "--system", str(tmp_path / "none.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text('{"tick": 0.012, "instances": [{"fmu": "x.fmu"}]}')
    assert main(["run", "--system", str(bad)]) == 2
    assert "instances.0: 'name' is a required property" in capsys.readouterr().err  # the schema names the field
    worse = tmp_path / "worse.json"
    worse.write_text('{"tick": 0.012, "instances": [{"name": "a", "fmu": "a.fmu", "period": 0.02}]}')
    assert main(["run", "--system", str(worse)]) == 2
    assert "not a whole multiple of the tick" in capsys.readouterr().err


@pytest.mark.parametrize("change, needle", [
    ({"conections": []}, "(top level): Additional properties are not allowed ('conections' was unexpected)"),
    ({"auto_connect": "false"}, "auto_connect: 'false' is not of type 'boolean'"),
    ({"auto_connect": 0}, "auto_connect: 0 is not of type 'boolean'"),
    ({"tick": "0.012"}, "tick: '0.012' is not of type 'number'"),
    ({"tick": 0}, "tick: 0 is less than or equal to the minimum of 0"),
    ({"connections": [{"source": "plant.x", "target": "sensors.x", "delay": 1.5}]}, "connections.0.delay: 1.5 is not of type 'integer'"),
    ({"connections": [{"source": "plant.x", "target": "sensors.x", "delay": True}]}, "connections.0.delay: True is not of type 'integer'"),
    ({"instances": [{"name": "", "fmu": "x.fmu"}]}, "instances.0.name: '' does not match"),
    ({"instances": [{"name": "a\\nb", "fmu": "x.fmu"}]}, "instances.0.name"),
    ({"instances": [{"name": "plant", "fmu": "x.fmu", "paramters": {"seed": "abc"}}]}, "'paramters' was unexpected"),
])
def test_a_malformed_system_description_names_the_field(tmp_path, capsys, change, needle):
    data = {"tick": 0.012, "instances": [{"name": "plant", "fmu": "TiltloadPlant.fmu"}], **change}
    path = tmp_path / "system.json"
    path.write_text(json.dumps(data).replace("\\\\n", "\\n"))
    assert main(["run", "--system", str(path), "--out", str(tmp_path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1 and "Traceback" not in err, err
