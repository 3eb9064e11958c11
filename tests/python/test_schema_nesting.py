"""Elements out of the FMI 2.0 schema's place: fmpy's validator (lxml against the schema)
and the orchestrator's importer must agree on which descriptions they refuse and on the
line, and both must accept a `<Tool>`'s free content.

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

#: (case, text to find in the description, its replacement, the misplaced element whose
#: line fmpy and we must both name, or None when both must accept).
CASES = [
    (
        "unknown element among the variables",
        "    <!-- 1 -->\n",
        "    <Foo/>\n    <!-- 1 -->\n",
        "<Foo>",
    ),
    (
        "child in a variable's type element",
        '<Real unit="N" start="0"/>',
        '<Real unit="N" start="0"><Real/></Real>',
        "<Real>",
    ),
    (
        "child in DefaultExperiment",
        'stepSize="0.0078125"/>',
        'stepSize="0.0078125"><Tolerance/></DefaultExperiment>',
        "<Tolerance>",
    ),
    (
        "FMI 3 style Annotations at the root",
        "  <ModelVariables>\n",
        '  <Annotations><Tool name="t"/></Annotations>\n  <ModelVariables>\n',
        "<Annotations>",
    ),
    (
        "free content in a vendor annotation",
        "  <ModelVariables>\n",
        '  <VendorAnnotations><Tool name="t"><Any><Deeper x="1"/></Any></Tool>'
        "</VendorAnnotations>\n  <ModelVariables>\n",
        None,
    ),
]


def repack(source: Path, target: Path, edit: tuple[str, str]) -> str:
    """Copies the FMU with one edit to its model description; returns the edited text."""
    with zipfile.ZipFile(source) as zin, zipfile.ZipFile(target, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                assert text.count(edit[0]) >= 1, f"fixture lacks {edit[0]!r}"
                text = text.replace(edit[0], edit[1], 1)
                data = text.encode()
                edited = text
            zout.writestr(item, data)
    return edited


@pytest.mark.parametrize("case,find,replace,element", CASES, ids=[c[0] for c in CASES])
def test_fmpy_and_the_importer_agree(
    tmp_path: Path,
    fmu_dir: Path,
    orchestrator: Path,
    case: str,
    find: str,
    replace: str,
    element: str | None,
) -> None:
    source = fmu_dir / "ForeignOscillator.fmu"
    assert source.is_file(), f"{source} missing: run `cargo xtask fmu`"
    fmu = tmp_path / "edited.fmu"
    text = repack(source, fmu, (find, replace))

    fmpy_problems = validate_fmu(str(fmu))
    ours = subprocess.run(
        [str(orchestrator), "info", str(fmu)], capture_output=True, text=True, timeout=60
    )
    if element is None:
        assert fmpy_problems == [], f"{case}: fmpy refused {fmpy_problems}"
        assert ours.returncode == 0, f"{case}: we refused:\n{ours.stderr}"
        return

    # The line of the misplaced element's start tag, from the edited text itself.
    tag = element.strip("<>")
    line = next(
        i
        for i, row in enumerate(text.splitlines(), 1)
        if re.search(rf"<{tag}[ />]", row) and (tag != "Real" or "<Real/>" in row)
    )
    assert any(f"line {line}" in p for p in fmpy_problems), (
        f"{case}: fmpy did not name line {line}: {fmpy_problems}"
    )
    assert ours.returncode != 0, f"{case}: we accepted it:\n{ours.stdout}"
    assert f"line {line}: " in ours.stderr and f"{element} is not allowed here" in ours.stderr, (
        f"{case}: expected line {line} and {element} in:\n{ours.stderr}"
    )
