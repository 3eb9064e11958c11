"""Elements and attributes out of the FMI 2.0 schema's place, and variable names outside
their naming convention: fmpy's validator (lxml against the schema, its name checks) and
the orchestrator's importer must agree on which descriptions they refuse and on the line,
and both must accept a `<Tool>`'s free content and the `xsi:` attributes every element may
carry.

Each case edits the model description of the foreign test FMU (`ForeignOscillator.fmu`,
built by `cargo xtask fmu`) and repacks it; `orchestrator info` opens an FMU fully
(unpack, parse, validate, load), so it refuses what the importer refuses.
"""

from __future__ import annotations

import re
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy.validation import validate_fmu

#: (case, edits (text to find in the description, its replacement), expected), where
#: expected is None when both must accept, else (a text on the line fmpy must name, a text
#: on the line we must name, words of our message). The lines differ only where noted.
CASES = [
    (
        "unknown element among the variables",
        [("    <!-- 1 -->\n", "    <Foo/>\n    <!-- 1 -->\n")],
        ("<Foo", "<Foo", "<Foo> is not allowed here"),
    ),
    (
        "child in a variable's type element",
        [('<Real unit="N" start="0"/>', '<Real unit="N" start="0"><Real/></Real>')],
        ("<Real/>", "<Real/>", "<Real> is not allowed here"),
    ),
    (
        "child in DefaultExperiment",
        [('stepSize="0.0078125"/>', 'stepSize="0.0078125"><Tolerance/></DefaultExperiment>')],
        ("<Tolerance", "<Tolerance", "<Tolerance> is not allowed here"),
    ),
    (
        "FMI 3 style Annotations at the root",
        [("  <ModelVariables>\n", '  <Annotations><Tool name="t"/></Annotations>\n  <ModelVariables>\n')],
        ("<Annotations", "<Annotations", "<Annotations> is not allowed here"),
    ),
    (
        "DefaultExperiment before LogCategories",
        [
            ('  <DefaultExperiment startTime="0" stopTime="2" stepSize="0.0078125"/>\n', ""),
            (
                "  <LogCategories>\n",
                '  <DefaultExperiment stopTime="2"/>\n  <LogCategories>\n',
            ),
        ],
        ("<LogCategories>", "<LogCategories>", "<LogCategories> is out of order"),
    ),
    (
        "a second DefaultExperiment",
        [("  <ModelVariables>\n", '  <DefaultExperiment stopTime="3"/>\n  <ModelVariables>\n')],
        ('stopTime="3"', 'stopTime="3"', "<DefaultExperiment> is one too many"),
    ),
    (
        "Annotations before the variable's type element",
        [('<Real unit="N" start="0"/>', '<Annotations><Tool name="t"/></Annotations><Real unit="N" start="0"/>')],
        ("<Annotations>", "<Annotations>", "<Annotations> is not allowed here"),
    ),
    (
        "a type element too many",
        [('<Real unit="N" start="0"/>\n', '<Real unit="N" start="0"/>\n      <Integer/>\n')],
        # The typed reading refuses the variable itself, naming it, at its start tag.
        ("<Integer/>", '<ScalarVariable name="drive"', "needs exactly one of"),
    ),
    (
        "LogCategories without a category",
        [
            (
                "".join(
                    f'    <Category name="{name}" description="{text}"/>\n'
                    for name, text in [
                        ("logEvents", "Lifecycle calls"),
                        ("logStatusWarning", "Calls that return fmi2Warning"),
                        ("logStatusDiscard", "Calls that return fmi2Discard"),
                        ("logStatusError", "Calls that return fmi2Error"),
                        ("logStatusFatal", "Calls that return fmi2Fatal"),
                    ]
                ),
                "",
            )
        ],
        ("<LogCategories>", "<LogCategories>", "LogCategories: misses <Category>"),
    ),
    (
        "free content in a vendor annotation",
        [
            (
                "  <ModelVariables>\n",
                '  <VendorAnnotations><Tool name="t"><Any><Deeper x="1"/><More/></Any></Tool>'
                "</VendorAnnotations>\n  <ModelVariables>\n",
            )
        ],
        None,
    ),
    (
        "an attribute the schema does not define",
        [('<ScalarVariable name="drive"', '<ScalarVariable foo="1" name="drive"')],
        ('foo="1"', 'foo="1"', "attribute 'foo' is not defined for <ScalarVariable>"),
    ),
    (
        "an attribute of another type element",
        [('<Real unit="N" start="0"/>', '<Real unit="N" start="0" declaredType="x" reinit="false" causality="input"/>')],
        ('causality="input"/>', 'causality="input"/>', "attribute 'causality' is not defined for <Real>"),
    ),
    (
        "an undefined attribute in a start tag over several lines",
        [('    canSerializeFMUstate="true"\n', '    canSerializeFMUstate="true"\n    bar="2"\n')],
        # libxml2 names the line the start tag ends on; we name the attribute's.
        ('canNotUseMemoryManagementFunctions="true"/>', 'bar="2"', "attribute 'bar' is not defined for <CoSimulation>"),
    ),
    (
        "a duplicated attribute",
        [('<ScalarVariable name="drive"', '<ScalarVariable name="x0" name="drive"')],
        ('name="x0"', 'name="x0"', "duplicated attribute"),
    ),
    (
        "text among the variables",
        [("    <!-- 1 -->\n", "    <!-- 1 -->\n    drive:\n")],
        # libxml2 names the line of the element holding the text; we name the text's.
        ("<ModelVariables>", "drive:", "ModelVariables: text is not allowed here"),
    ),
    (
        "text in a variable's type element",
        [('<Real unit="N" start="0"/>', '<Real unit="N" start="0">0.5</Real>')],
        (">0.5<", ">0.5<", "Real: text is not allowed here"),
    ),
    (
        "text in a vendor annotation",
        [
            (
                "  <ModelVariables>\n",
                '  <VendorAnnotations><Tool name="t"><Any>free &amp; text</Any></Tool>'
                "</VendorAnnotations>\n  <ModelVariables>\n",
            )
        ],
        None,
    ),
    (
        "a tab in a flat name",
        [('<ScalarVariable name="drive"', '<ScalarVariable name="dr&#9;ive"')],
        ('name="dr&#9;ive"', 'name="dr&#9;ive"', "name holds a tab at character 3"),
    ),
    (
        "a space in a structured name",
        [
            ('variableNamingConvention="flat"', 'variableNamingConvention="structured"'),
            ('<ScalarVariable name="drive"', '<ScalarVariable name="drive force"'),
        ],
        ('name="drive force"', 'name="drive force"', "name is not a structured name"),
    ),
    (
        "structured names that follow the grammar",
        [('variableNamingConvention="flat"', 'variableNamingConvention="structured"')],
        None,
    ),
    (
        "xsi attributes",
        [
            (
                'numberOfEventIndicators="0">',
                'numberOfEventIndicators="0" '
                'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
                'xsi:noNamespaceSchemaLocation="fmi2ModelDescription.xsd">',
            )
        ],
        None,
    ),
]


def repack(source: Path, target: Path, edits: list[tuple[str, str]]) -> str:
    """Copies the FMU with edits to its model description; returns the edited text."""
    with zipfile.ZipFile(source) as zin, zipfile.ZipFile(target, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                for find, replace in edits:
                    assert find in text, f"fixture lacks {find!r}"
                    text = text.replace(find, replace, 1)
                data = text.encode()
                edited = text
            zout.writestr(item, data)
    return edited


@pytest.mark.parametrize("case,edits,expected", CASES, ids=[c[0] for c in CASES])
def test_fmpy_and_the_importer_agree(
    tmp_path: Path,
    fmu_dir: Path,
    orchestrator: Path,
    case: str,
    edits: list[tuple[str, str]],
    expected: tuple[str, str] | None,
) -> None:
    source = fmu_dir / "ForeignOscillator.fmu"
    assert source.is_file(), f"{source} missing: run `cargo xtask fmu`"
    fmu = tmp_path / "edited.fmu"
    text = repack(source, fmu, edits)

    fmpy_problems = validate_fmu(str(fmu))
    ours = subprocess.run(
        [str(orchestrator), "info", str(fmu)], capture_output=True, text=True, timeout=60
    )
    if expected is None:
        assert fmpy_problems == [], f"{case}: fmpy refused {fmpy_problems}"
        assert ours.returncode == 0, f"{case}: we refused:\n{ours.stderr}"
        return

    fmpy_marker, our_marker, words = expected
    rows = text.splitlines()
    fmpy_line = next(i for i, row in enumerate(rows, 1) if fmpy_marker in row)
    assert any(re.search(rf"line {fmpy_line}\b", p) for p in fmpy_problems), (
        f"{case}: fmpy did not name line {fmpy_line}: {fmpy_problems}"
    )
    line = next(i for i, row in enumerate(rows, 1) if our_marker in row)
    assert ours.returncode != 0, f"{case}: we accepted it:\n{ours.stdout}"
    # Validation problems read "line N: ...", a description the parse refuses "file:N: ...".
    named = f"line {line}: " in ours.stderr or f"modelDescription.xml:{line}: " in ours.stderr
    assert named and words in ours.stderr, (
        f"{case}: expected line {line} and {words!r} in:\n{ours.stderr}"
    )
