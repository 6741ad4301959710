"""modelDescription.xml of the FMU (FMI 2.0, co-simulation)."""

from __future__ import annotations

import datetime
import xml.etree.ElementTree as ET

from maniplab.fmu.variables import UNITS, Variable
from maniplab.model.version import package_version

STOP_TIME = 5.0
"""The default experiment's length, s."""


def model_description(*, name: str, identifier: str, guid: str, description: str, dt: float,
                      variables: list[Variable]) -> str:
    """The XML text.

    Args:
        name: the model's name (the arm's).
        identifier: the modelIdentifier (the shared library's name, a C identifier).
        guid: the FMU's GUID, which the library checks.
        description: one paragraph about the FMU.
        dt: the FMU's step, s (the default experiment's step size).
        variables: in value-reference order.
    """
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": name, "guid": guid, "description": description,
        "generationTool": f"maniplab {package_version()}",
        "generationDateAndTime": datetime.datetime.now(datetime.timezone.utc)
        .strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "flat", "numberOfEventIndicators": "0"})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": identifier, "canHandleVariableCommunicationStepSize": "true",
        "canNotUseMemoryManagementFunctions": "true", "canGetAndSetFMUstate": "false",
        "canSerializeFMUstate": "false", "providesDirectionalDerivative": "false"})
    _units(root, variables)
    categories = ET.SubElement(root, "LogCategories")
    for category in ("logError", "logWarning", "logAll"):
        ET.SubElement(categories, "Category", name=category)
    ET.SubElement(root, "DefaultExperiment", startTime="0", stopTime=repr(STOP_TIME),
                  stepSize=repr(dt))
    _variables(root, variables)
    _structure(root, variables)
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _units(root: ET.Element, variables: list[Variable]) -> None:
    used = sorted({v.unit for v in variables if v.unit})
    if not used:
        return
    units = ET.SubElement(root, "UnitDefinitions")
    for name in used:
        unit = ET.SubElement(units, "Unit", name=name)
        ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS[name].items()})


def _variables(root: ET.Element, variables: list[Variable]) -> None:
    table = ET.SubElement(root, "ModelVariables")
    for vr, v in enumerate(variables):
        attributes = {"name": v.name, "valueReference": str(vr), "description": v.description,
                      "causality": v.causality}
        if v.causality == "parameter":
            attributes |= {"variability": "fixed", "initial": "exact"}
        elif v.causality == "output":
            attributes |= {"variability": "discrete" if v.type == "Integer" else "continuous",
                           "initial": "calculated"}
        else:
            attributes["variability"] = "continuous"
        element = ET.SubElement(table, "ScalarVariable", attributes)
        typed = {"unit": v.unit} if v.unit else {}
        if v.start is not None:
            typed["start"] = repr(float(v.start))
        ET.SubElement(element, v.type, typed)


def _structure(root: ET.Element, variables: list[Variable]) -> None:
    structure = ET.SubElement(root, "ModelStructure")
    outputs = ET.SubElement(structure, "Outputs")
    initial = ET.SubElement(structure, "InitialUnknowns")
    for i, v in enumerate(variables):
        if v.causality == "output":  # no direct feed-through: an input acts over the next step
            ET.SubElement(outputs, "Unknown", index=str(i + 1), dependencies="")
            ET.SubElement(initial, "Unknown", index=str(i + 1))
