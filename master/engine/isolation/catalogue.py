"""The FMUs a server offers (those of one folder, a client picks one by model identifier and GUID), and the refusals
of a request it cannot grant."""

from __future__ import annotations

import threading
from pathlib import Path

from ..errors import DescriptionError
from ..fmi.model_description import read_fmu
from .elf import library_machine, this_machine


class Refused(Exception):
    """A client's request this server does not grant; the message goes to the client and the log."""


class Catalogue:
    """The FMUs of the folder by model identifier and GUID, read again whenever a file changes."""

    def __init__(self, folder: Path, say) -> None:
        self.folder, self.say = Path(folder), say
        self._known: dict[Path, tuple] = {}  # path -> ((mtime, size), model description or None)
        self._lock = threading.Lock()

    def entries(self) -> list[tuple[Path, object]]:
        with self._lock:
            found = []
            for path in sorted(self.folder.glob("*.fmu")):
                try:
                    st = path.stat()
                except OSError:
                    continue
                stamp = (st.st_mtime_ns, st.st_size)
                if self._known.get(path, (None,))[0] != stamp:
                    try:
                        md = read_fmu(path, path.stem)
                    except DescriptionError as err:
                        self.say(f"not served: {err}")
                        md = None
                    self._known[path] = (stamp, md)
                md = self._known[path][1]
                if md is not None:
                    found.append((path, md))
            return found

    def find(self, model_identifier: str, guid: str) -> Path:
        entries = self.entries()
        for path, md in entries:
            if md.coSimulation.modelIdentifier == model_identifier and md.guid == guid:
                built_for = library_machine(path, model_identifier)
                if built_for is not None and built_for != this_machine():
                    raise Refused(f"{path.name} here holds a library for {built_for}, this machine is {this_machine()}: "
                                  "build the FMU for it (docs/remote.md)")
                return path
        same = [(path, md.guid) for path, md in entries if md.coSimulation.modelIdentifier == model_identifier]
        if same:
            path, other = same[0]
            raise Refused(f"{path.name} here is {model_identifier} with GUID {other}, the master's has {guid}: "
                          "build the same version on both machines")
        have = ", ".join(sorted({md.coSimulation.modelIdentifier for _, md in entries})) or "none"
        raise Refused(f"no FMU {model_identifier} in the served folder (it has: {have})")
