"""Benchmark of quaketwin.fleet (issues 17 and 33): the four sample events × N
copies run through the post-earthquake pipeline on the fleet's own local
cluster (``quaketwin.fleet.local_cluster()``: one worker process per core),
against the command line's own parallel many-event run of the same events
(both the same build).  The two alternate ``--repeat`` times (the machine
may be shared: alternating spreads its load over both); prints each run,
then the medians, the spread and the engine's overhead (median over median).

    python3 scripts/fleet_bench.py [--copies 50] [--repeat 3] [--bin target/release/quaketwin]

``--dask-defaults`` runs the fleet on a plain ``LocalCluster(n_workers=2,
threads_per_worker=1)`` instead (Dask's default settings: the cluster the
benchmark used before issue 33).
"""

import argparse
import os
import pathlib
import shutil
import statistics
import subprocess
import tempfile
import time

import quaketwin.fleet

ROOT = pathlib.Path(__file__).resolve().parents[1]


def run_cli(binary, pipeline, events_dir, out):
    t0 = time.perf_counter()
    subprocess.run([binary, "-q", "run", pipeline, events_dir, "--out", out], check=True,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def run_fleet(pipeline, events, out, dask_defaults):
    from dask.distributed import Client, LocalCluster

    if dask_defaults:
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None)
    else:
        cluster = quaketwin.fleet.local_cluster()
    with cluster, Client(cluster) as client:
        # The cluster's start (process spawns, imports) is not the engine's
        # per-event cost: the clock starts once every worker is up.
        client.wait_for_workers(len(cluster.workers))
        t0 = time.perf_counter()
        runs = quaketwin.fleet.run(pipeline, events, out, client=client, progress=False)
        seconds = time.perf_counter() - t0
    ok = sum(1 for s in runs.column("status").to_pylist() if s == "ok")
    if ok != len(events):
        raise SystemExit(f"fleet: {ok} of {len(events)} events ok")
    return seconds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--copies", type=int, default=50)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "quaketwin"))
    ap.add_argument("--dask-defaults", action="store_true")
    args = ap.parse_args()
    samples = sorted(p for p in (ROOT / "sample-records").iterdir() if (p / "event.toml").is_file())
    pipeline = ROOT / "pipelines" / "post-earthquake.toml"
    with tempfile.TemporaryDirectory() as work:
        work = pathlib.Path(work)
        events_dir = work / "events"
        events = []
        for k in range(args.copies):
            for s in samples:
                dst = events_dir / f"{s.name}-{k:03d}"
                shutil.copytree(s, dst)
                events.append(dst)
        n = len(events)
        print(f"events: {n} ({len(samples)} samples x {args.copies}), {os.cpu_count()} cores", flush=True)
        cli, fleet = [], []
        for r in range(args.repeat):
            cli.append(run_cli(args.bin, pipeline, events_dir, work / "cli"))
            shutil.rmtree(work / "cli")
            fleet.append(run_fleet(pipeline, events, work / "fleet", args.dask_defaults))
            shutil.rmtree(work / "fleet")
            print(f"  round {r + 1}: CLI {cli[-1]:.1f} s, fleet {fleet[-1]:.1f} s "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)
        c, f = statistics.median(cli), statistics.median(fleet)
        print(f"CLI parallel run: median {c:.1f} s ({min(cli):.1f}–{max(cli):.1f}), {n / c:.2f} events/s")
        print(f"fleet: median {f:.1f} s ({min(fleet):.1f}–{max(fleet):.1f}), {n / f:.2f} events/s")
        print(f"engine overhead: {100 * (f / c - 1):+.1f} % wall time (median over median)")


if __name__ == "__main__":
    main()
