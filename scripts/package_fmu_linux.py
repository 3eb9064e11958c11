"""Packages the FMU crates' shared libraries of the `mutants` profile into OUT/<id>.fmu
(modelDescription.xml and binaries/linux64 only): the quick packaging of
scripts/mutants_fmu.sh, where `cargo xtask fmu` (release, win64, documentation) would cost
minutes per mutant. Each archive is written to a temporary file and renamed.

Usage: python3 scripts/package_fmu_linux.py REPO OUT
"""

import os
import pathlib
import re
import sys
import zipfile

repo, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
for crate in ("fmu-plant", "fmu-controller"):
    manifest = (repo / crate / "Cargo.toml").read_text()
    lib = re.search(r'^\[lib\]\s*\nname = "([^"]+)"', manifest, re.M).group(1)
    xml_path = re.search(r'model-description = "([^"]+)"', manifest).group(1)
    xml = (repo / crate / xml_path).resolve().read_text()
    ident = re.search(r'<CoSimulation[^>]*modelIdentifier="([^"]+)"', xml, re.S).group(1)
    tmp = out / f"{ident}.fmu.tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", xml)
        z.write(repo / "target" / "mutants" / f"lib{lib}.so", f"binaries/linux64/{ident}.so")
    os.replace(tmp, out / f"{ident}.fmu")
