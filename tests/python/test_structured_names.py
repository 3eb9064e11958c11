"""Structured variable names, drawn at random: fmpy's validator (its grammar of FMI 2.0
§2.2.9, run by lark) and the orchestrator's importer (`fmi2-md/src/names.rs`, written
independently) must refuse the same names.

One FMU holds all the drawn names at once: the foreign test FMU (`ForeignOscillator.fmu`,
built by `cargo xtask fmu`) with its naming convention set to `structured` and one extra
parameter per name, each on its own line, so that both tools' reports map to names by line.

The draw leaves out the backslash and the double quote, and uses at most two single quotes
per name. fmpy reads the grammar's escapes (`\\'`, `\\"`, `\\n`, ...) as the single
characters they stand for, not as the two-character sequences the standard writes: it
accepts a bare `"` inside a quoted name, and a third `'` that it may take for an escape,
where the standard (and the importer) need `\\"` and `\\'`. The two readings differ there by
design, so those names are left out (a draw of 2,000 names that allowed `"` found one to
four such names per seed, each with a bare `"` between quotes, and no other difference).
"""

from __future__ import annotations

import random
import re
import subprocess
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

from fmpy.validation import validate_fmu

#: Characters a mutation inserts or substitutes: the grammar's own, and a few that no
#: structured name may hold outside quotes.
MUTATIONS = list("az_Z09.[],() '$-#") + ["ä", "der("]

#: Quoted-name characters: the standard's q-char, which holds neither quote nor backslash.
Q_CHARS = "ab_Z09!#$%&()*+,-./:;<=>?@[]^{}|~ "

#: How many names are drawn; the seed makes the draw the same on every run.
NAMES = 400
SEED = 20261202


def b_name(rng: random.Random, quoted: bool) -> str:
    if quoted:
        return "'" + "".join(rng.choice(Q_CHARS) for _ in range(rng.randint(1, 5))) + "'"
    head = rng.choice("abxyzAB_")
    return head + "".join(rng.choice("abc_019Z") for _ in range(rng.randint(0, 3)))


def grammatical(rng: random.Random) -> str:
    """A name the grammar derives, with at most one quoted part."""
    quoted = rng.randrange(3) if rng.random() < 0.3 else -1
    parts = []
    for i in range(rng.randint(1, 3)):
        part = b_name(rng, i == quoted)
        if rng.random() < 0.4:
            part += "[" + ",".join(str(rng.randint(0, 12)) for _ in range(rng.randint(1, 3))) + "]"
        parts.append(part)
    name = ".".join(parts)
    if rng.random() < 0.2:
        name = f"der({name}" + (f",{rng.randint(1, 3)}" if rng.random() < 0.5 else "") + ")"
    return name


def draw(rng: random.Random) -> str:
    """A grammatical name, half of the time with one character inserted, removed or
    replaced."""
    while True:
        name = grammatical(rng)
        if rng.random() < 0.5:
            at = rng.randrange(len(name) + 1)
            how = rng.choice(["insert", "remove", "replace"])
            if how == "insert":
                name = name[:at] + rng.choice(MUTATIONS) + name[at:]
            elif how == "remove":
                name = name[:at] + name[at + 1 :]
            else:
                name = name[:at] + rng.choice(MUTATIONS) + name[at + 1 :]
        if name and name.count("'") <= 2:
            return name


def test_fmpy_and_the_importer_refuse_the_same_structured_names(
    tmp_path: Path, fmu_dir: Path, orchestrator: Path
) -> None:
    source = fmu_dir / "ForeignOscillator.fmu"
    assert source.is_file(), f"{source} missing: run `cargo xtask fmu`"
    with zipfile.ZipFile(source) as zin:
        text = zin.read("modelDescription.xml").decode()
    # Names must stay unique, so none is drawn twice or repeats one of the FMU's.
    taken = set(re.findall(r'<ScalarVariable name="([^"]*)"', text))
    # Names every reading accepts and refuses, so the comparison cannot pass vacuously.
    names = ["a.b[1,2].c", "der(y.z,2)", "'it is'.x", "1x", "a..b", "der(x"]
    rng = random.Random(SEED)
    while len(names) < NAMES:
        name = draw(rng)
        if name not in names and name not in taken:
            names.append(name)
    assert 'variableNamingConvention="flat"' in text and "</ModelVariables>" in text
    text = text.replace(
        'variableNamingConvention="flat"', 'variableNamingConvention="structured"', 1
    )
    extra = "".join(
        f'    <ScalarVariable name={quoteattr(name)} valueReference="{1000 + i}" '
        f'causality="parameter" variability="fixed"><Real start="0"/></ScalarVariable>\n'
        for i, name in enumerate(names)
    )
    text = text.replace("</ModelVariables>", extra + "  </ModelVariables>", 1)
    rows = text.splitlines()
    first = next(i for i, row in enumerate(rows, 1) if 'valueReference="1000"' in row)
    name_at = {first + i: name for i, name in enumerate(names)}
    # The FMU's own names must be structured names too, or the comparison is not clean.
    assert max(name_at) < len(rows)

    fmu = tmp_path / "names.fmu"
    with zipfile.ZipFile(source) as zin, zipfile.ZipFile(fmu, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = text.encode()
            zout.writestr(item, data)

    fmpy_refused = set()
    for problem in validate_fmu(str(fmu)):
        m = re.search(r"\(line (\d+)\) is not a legal variable name", problem)
        assert m, f"fmpy found another problem: {problem}"
        fmpy_refused.add(name_at[int(m.group(1))])

    ours = subprocess.run(
        [str(orchestrator), "info", str(fmu)], capture_output=True, text=True, timeout=60
    )
    our_refused = set()
    for line in re.findall(r"line (\d+): [^\n]*not a structured name", ours.stderr):
        our_refused.add(name_at[int(line)])
    other = [
        row
        for row in ours.stderr.splitlines()
        if re.search(r"line \d+: ", row) and "not a structured name" not in row
    ]
    assert not other, f"we found other problems: {other}"

    assert "1x" in our_refused and "a.b[1,2].c" not in our_refused
    assert 50 < len(our_refused) < len(names) - 50, (
        f"the draw is lopsided: {len(our_refused)} of {len(names)} refused"
    )
    only_fmpy = sorted(fmpy_refused - our_refused)
    only_ours = sorted(our_refused - fmpy_refused)
    assert not only_fmpy and not only_ours, (
        f"refused by fmpy only: {only_fmpy}\nrefused by us only: {only_ours}"
    )
