"""The Dask driver: shards run as tasks on a LocalCluster of two workers merge into exactly
the files of a plain `orchestrator sweep` run."""

from __future__ import annotations

import subprocess
from pathlib import Path

from dask.distributed import Client, LocalCluster

from dask_sweep import run_sweep


def write_sweep(tmp: Path, fmu_dir: Path) -> Path:
    (tmp / "base.toml").write_text(
        f"""step_size = 0.001
stop_time = 0.3
trials = 3
[[fmu]]
name = "controller"
path = "{fmu_dir / 'HlcsController.fmu'}"
[fmu.parameters]
trajectory = "circle"
duration = 0.3
[[fmu]]
name = "plant"
path = "{fmu_dir / 'CkcmPlant.fmu'}"
[[connection]]
from = "plant.length"
to = "controller.length"
[[connection]]
from = "plant.velocity"
to = "controller.velocity"
[[connection]]
from = "controller.force"
to = "plant.force"
[[memory]]
from = "controller.memory_next"
to = "controller.memory"
[metrics]
error = "controller.error"
"""
    )
    sweep = tmp / "sweep.toml"
    sweep.write_text(
        """base = "base.toml"
combine = "zip"
seed = 11
[[axis]]
name = "mass"
parameters = ["plant.platform_mass"]
scale = true
lhs = [0.7, 1.3]
samples = 5
[[axis]]
name = "gain"
parameters = ["controller.phi"]
normal = [47728.0, 2000.0]
samples = 5
"""
    )
    return sweep


def result_files(out: Path) -> dict[str, bytes]:
    files = {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    # Only what the results consist of: the table, the report, the figures and each case.
    return {k: v for k, v in files.items() if not k.endswith(".tmp")}


def test_dask_shards_merge_to_the_plain_run(tmp_path: Path, fmu_dir: Path, orchestrator: Path) -> None:
    sweep = write_sweep(tmp_path, fmu_dir)
    plain = tmp_path / "plain"
    subprocess.run([str(orchestrator), "sweep", str(sweep), "--out", str(plain)], check=True, capture_output=True)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(
        cluster
    ) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        merged = run_sweep(orchestrator, sweep, tmp_path / "dask", 3, client)
    want = result_files(plain)
    got = result_files(merged)
    assert "sweep.csv" in want and "figures/envelope.svg" in want
    assert sorted(want) == sorted(got)
    for name in want:
        assert want[name] == got[name], f"{name} differs between the plain and the Dask run"
    rows = want["sweep.csv"].decode().splitlines()
    assert len(rows) == 6, rows
