"""The names every SSP package of ours shares (annotations, namespaces, member names) and the check of a document
against the SSP schemas pyssp-standard ships. What a package holds: docs/master.md (SSP packages)."""

from __future__ import annotations

import functools
import io

ANNOTATION = "org.tiltload.master"
TL_NS = "https://github.com/tiltload/ssp/1"
OSP_ANNOTATION = "com.opensimulationplatform"
OSP_NS = "http://opensimulationplatform.com/SSP/OSPAnnotations"
FMU_TYPE = "application/x-fmu-sharedlibrary"
SSD_NAME = "SystemStructure.ssd"
SCHEDULES = ("ordered", "jacobi")
PARAMETER_SET = "initialValues"  # every component's SSV set has this name: Ecos applies a set by name (init(parameter_set=...))
SSD_NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
          "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
          "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues", "tl": TL_NS}


@functools.cache
def _schema(kind: str):  # building one takes 0.5 s
    import xmlschema
    from pyssp_standard.standard import ModelicaStandard

    version = xmlschema.XMLSchema11 if kind.endswith("_11") else xmlschema.XMLSchema10
    return version(str(ModelicaStandard.schemas[kind]))


def schema_errors(xml: bytes, kind: str = "ssd") -> list[str]:
    """The SSP schema's complaints about a document (kind ssd or ssv: SSP 1.0; ssd2, ssv2: SSP 2.0, ssd2_11 its XSD 1.1
    form, pyssp-standard's names); empty if it validates."""
    schema = _schema(kind)
    try:
        return [f"{e.path}: {e.reason}" for e in schema.iter_errors(io.BytesIO(xml))]
    except Exception as err:  # not XML at all
        return [str(err)]

