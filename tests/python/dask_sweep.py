"""Run an `orchestrator sweep` on a Dask distributed cluster, one task per shard, and merge.

Each task runs `orchestrator sweep SWEEP --shard K/N --out OUT/shards/K` on a worker; when
all have finished, `orchestrator sweep merge` combines the shard folders into OUT, exactly
the files an unsharded run writes. Workers need the orchestrator binary, the FMUs and OUT on
a shared file system (as on any cluster with a common home or scratch directory).

    python dask_sweep.py SWEEP.toml --out OUT --shards 8                       # LocalCluster
    python dask_sweep.py SWEEP.toml --out OUT --shards 64 --scheduler tcp://host:8786

A finished shard is skipped when the driver runs again (`--resume` on every shard), so an
interrupted study continues where it stopped.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from dask.distributed import Client, LocalCluster


def run_shard(orchestrator: str, sweep: str, shard_dir: str, k: int, n: int) -> str:
    """One shard on a worker; raises with the orchestrator's message when it fails."""
    cmd = [orchestrator, "sweep", sweep, "--out", shard_dir, "--shard", f"{k}/{n}", "--jobs", "1"]
    if Path(shard_dir).exists():
        cmd.append("--resume")
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"shard {k}/{n} failed: {done.stderr.strip()}")
    return shard_dir


def run_sweep(
    orchestrator: Path,
    sweep: Path,
    out: Path,
    shards: int,
    client: Client,
) -> Path:
    """Submits every shard to `client`, waits for all, then merges them into `out`."""
    shard_root = out.parent / f"{out.name}.shards"
    futures = [
        client.submit(
            run_shard,
            str(orchestrator),
            str(sweep),
            str(shard_root / f"{k}"),
            k,
            shards,
            key=f"sweep-shard-{k}-of-{shards}",
            pure=False,
        )
        for k in range(shards)
    ]
    dirs = client.gather(futures)
    subprocess.run(
        [str(orchestrator), "sweep", "merge", str(sweep), *dirs, "--out", str(out)],
        check=True,
        capture_output=True,
    )
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("sweep", type=Path)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--shards", type=int, default=os.cpu_count() or 1)
    p.add_argument("--scheduler", help="address of a running Dask scheduler (default: a LocalCluster)")
    p.add_argument("--orchestrator", type=Path, default=Path("target/release/orchestrator"))
    a = p.parse_args()
    if a.scheduler:
        client = Client(a.scheduler)
    else:
        client = Client(LocalCluster(n_workers=min(a.shards, os.cpu_count() or 1), threads_per_worker=1))
    with client:
        out = run_sweep(a.orchestrator.resolve(), a.sweep.resolve(), a.out.resolve(), a.shards, client)
    print(f"merged sweep in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
