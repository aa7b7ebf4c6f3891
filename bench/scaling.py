"""Scaling of one integration job over devices, sub-devices and Dask workers.

    python bench/scaling.py                  # the full benchmark: a job of >= 30 s on one core
    python bench/scaling.py --seconds 5      # a short run (noisy machines, smoke tests)
    python bench/scaling.py --repeat 3       # every configuration 3 times, round robin; best of each
    python bench/scaling.py --json out.json  # also write every figure as JSON

Every configuration runs in its own process (fresh PoCL thread pool, its own
environment) on the *same* job: the same integrand, seed and sample count,
sized so that the one-core baseline takes ``--seconds``.

Configurations:

  device     one PoCL device: PoCL runs its kernels on a pool of one thread
             per core (both cores here)
  one-core   the same device with POCL_MAX_PTHREAD_COUNT=1: one core
  sub1       one sub-device of --split 2
  sub2       two sub-devices (--split 2)
  dask1      a LocalCluster of 1 worker process (1 thread, PoCL 1 thread)
  dask2      a LocalCluster of 2 worker processes (each 1 thread, PoCL 1 thread)

Why both "sub1" and "one-core": PoCL 3's pthread driver keeps ONE thread pool
for all devices, so a sub-device of one compute unit still runs its kernels
on every core (measured: sub1 ~ device).  The two sub-devices therefore share
the same cores as one device does; the honest "one device's worth of cores"
baseline for the sub-device scaling is one-core.  Dask workers are separate
processes, each with its own one-thread pool: there 1 -> 2 is a real doubling
of the cores used.

Rates are reported per wall second and per CPU second of the processes that
computed, and "cores" is CPU seconds / wall seconds: what the run really got.
On a shared machine a CPU-second rate that stays constant while the wall rate
and "cores" drop means the cores were busy with someone else; compare wall
rates only between runs that got the cores they asked for.  An idle Dask
worker process itself uses about 4 % of a core (measured), which shows in
its CPU-second rate.

The scheduling overhead per chunk is measured with a job whose launches cost
nothing (a null runner): wall time per chunk of the multi-device scheduler,
of the one-device scheduler and of a Dask task round trip.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

INTEGRAND = "exp(-x[0]*x[0] - 0.5f*x[1]*x[1] - 0.25f*x[2]*x[2] - 0.125f*x[3]*x[3])"
DIM = 4
SEED = 1

CONFIGS = {
    "device": "one PoCL device (PoCL pool: all cores)",
    "one-core": "one PoCL device, POCL_MAX_PTHREAD_COUNT=1 (one core)",
    "sub1": "one sub-device of --split 2 (PoCL pool: all cores)",
    "sub2": "two sub-devices, --split 2",
    "dask1": "Dask LocalCluster, 1 worker x 1 thread (PoCL 1 thread)",
    "dask2": "Dask LocalCluster, 2 workers x 1 thread (PoCL 1 thread each)",
}


def _cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system


# -- one configuration, in its own process ------------------------------------


def _cluster(workers: int):
    import logging

    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.CRITICAL, env={"POCL_MAX_PTHREAD_COUNT": "1"})
    return cluster, Client(cluster)


def _worker_cpu(client) -> float:
    return sum(client.run(_cpu_seconds).values())


def run_config(name: str, samples: int) -> dict:
    """Run the benchmark job in configuration ``name`` (in this process)."""
    import mcocl
    from mcocl.devices import sub_device_contexts

    last = {}

    def progress(p):
        last["rates"] = p.device_rates

    kw: dict = dict(dim=DIM, seed=SEED, progress=progress)
    cluster = client = None
    if name == "sub1":
        kw["device"] = sub_device_contexts(None, 2)[0].device
    elif name == "sub2":
        kw["split"] = 2
    elif name in ("dask1", "dask2"):
        cluster, client = _cluster(1 if name == "dask1" else 2)
        kw["client"] = client
    try:
        mcocl.integrate(INTEGRAND, samples=1e7, **kw)  # warm-up: builds, PoCL kernel cache
        cpu0 = _worker_cpu(client) if client else _cpu_seconds()
        r = mcocl.integrate(INTEGRAND, samples=samples, **kw)
        cpu = (_worker_cpu(client) if client else _cpu_seconds()) - cpu0
    finally:
        if client is not None:
            client.close()
            cluster.close()
    return {
        "config": name,
        "what": CONFIGS[name],
        "samples": r.samples,
        "seconds": r.seconds,
        "samples_per_second": r.samples / r.seconds,
        "cpu_seconds": cpu,
        "samples_per_cpu_second": r.samples / cpu if cpu > 0 else float("nan"),
        "estimate": r.estimate,
        "stderr": r.stderr,
        "device_rates": [(n, b) for n, b in last.get("rates", ())],
    }


# -- scheduling overhead -----------------------------------------------------------


@dataclass
class NullJob:
    """A job whose launches cost nothing: what is left is the scheduler's own time."""

    stat_shape: tuple[int, ...] = (8,)

    def runner(self, ctx) -> NullRunner:
        return NullRunner()


class NullRunner:
    """Returns zero statistics at once."""

    def enqueue(self, first_block: int, nblocks: int) -> int:
        return nblocks

    def collect(self, nblocks: int) -> np.ndarray:
        return np.zeros((nblocks, 8))


def run_overhead(chunks: int, dask_chunks: int) -> dict:
    """Seconds per chunk of the schedulers with a null job (one block per chunk)."""
    from mcocl.accumulate import Accumulator
    from mcocl.devices import sub_device_contexts
    from mcocl.engine.contract import Halting, Placement
    from mcocl.engine.multi_device import run_devices
    from mcocl.engine.one_device import run_one_device
    from mcocl.runtime import device_context

    out = {}
    acc = Accumulator((8,))
    rep = run_one_device(NullJob(), acc, Halting(max_blocks=chunks), device_context(None), chunk_seconds=1e-12)
    out["single_device_s_per_chunk"] = rep.seconds / rep.chunks
    acc = Accumulator((8,))
    rep = run_devices(NullJob(), acc, Halting(max_blocks=chunks), sub_device_contexts(None, 2), max_chunk=1)
    out["multi_device_s_per_chunk"] = rep.seconds / rep.chunks
    try:
        import distributed  # noqa: F401
    except ImportError:
        return out
    from mcocl.engine.dask_cluster import run_dask

    cluster, client = _cluster(2)
    try:
        run_dask(NullJob(), Accumulator((8,)), Halting(max_blocks=20), Placement(client=client), max_chunk=1)
        rep = run_dask(NullJob(), Accumulator((8,)), Halting(max_blocks=dask_chunks), Placement(client=client),
                       max_chunk=1)
        out["dask_s_per_task"] = rep.seconds / rep.chunks
    finally:
        client.close()
        cluster.close()
    return out


# -- driver ---------------------------------------------------------------------


def _child(args: list[str], env_extra: dict[str, str]) -> dict:
    env = {**os.environ, **env_extra}
    cmd = [sys.executable, str(Path(__file__).resolve()), *args]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def _env_for(name: str) -> dict[str, str]:
    return {"POCL_MAX_PTHREAD_COUNT": "1"} if name == "one-core" else {}


def _fmt_rate(v: float) -> str:
    return f"{v / 1e6:8.1f} M/s"


def _row(name: str, r: dict) -> str:
    # cores = CPU seconds / wall seconds: what the run actually got; well under
    # the cores it asked for means the machine was busy with other work.
    return (f"{name:<9} {_fmt_rate(r['samples_per_second']):>17} {r['seconds']:8.2f} "
            f"{_fmt_rate(r['samples_per_cpu_second']):>15} {r['cpu_seconds']:8.2f} "
            f"{r['cpu_seconds'] / r['seconds']:6.2f}  {r['what']}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=30.0, help="duration of the one-core baseline (default 30)")
    ap.add_argument("--configs", default=",".join(CONFIGS), help=f"comma-separated subset of {', '.join(CONFIGS)}")
    ap.add_argument("--repeat", type=int, default=1,
                    help="run every configuration this many times, round robin, and keep each one's best "
                         "(on a shared machine the best run is the one least disturbed; default 1)")
    ap.add_argument("--overhead-chunks", type=int, default=3000, help="null chunks for the overhead figures")
    ap.add_argument("--json", default=None, help="write all figures to this file")
    ap.add_argument("--run", default=None, help=argparse.SUPPRESS)  # internal: one configuration
    ap.add_argument("--samples", type=float, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--overhead", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()

    if a.run:
        print(json.dumps(run_config(a.run, int(a.samples))))
        return 0
    if a.overhead:
        print(json.dumps(run_overhead(a.overhead_chunks, max(a.overhead_chunks // 10, 50))))
        return 0

    names = [n.strip() for n in a.configs.split(",") if n.strip()]
    unknown = [n for n in names if n not in CONFIGS]
    if unknown:
        ap.error(f"unknown configurations: {', '.join(unknown)}")
    try:
        import distributed  # noqa: F401
    except ImportError:
        if any(n.startswith("dask") for n in names):
            print("dask.distributed is not installed: skipping dask1, dask2 (pip install 'mcocl[dask]')")
            names = [n for n in names if not n.startswith("dask")]

    load0 = os.getloadavg()
    t_start = time.time()
    # Size the job: the one-core rate from a short pilot, times --seconds.
    pilot = _child(["--run", "one-core", "--samples", "3e8"], _env_for("one-core"))
    samples = int(pilot["samples_per_second"] * a.seconds)
    print(f"job: {INTEGRAND} over [0,1]^{DIM}, {samples:.3g} samples "
          f"(~{a.seconds:g} s on one core at the pilot's {pilot['samples_per_second'] / 1e6:.1f} M samples/s)")
    print(f"machine: {os.cpu_count()} cores, load average before {load0[0]:.2f}")
    print()
    runs: dict[str, list[dict]] = {n: [] for n in names}
    header = (f"{'config':<9} {'samples/s (wall)':>17} {'wall s':>8} {'samples/cpu-s':>15} {'cpu s':>8} "
              f"{'cores':>6}  what")
    print(header)
    for rep in range(max(a.repeat, 1)):
        # Round robin, so a busy spell of the machine hits every configuration alike.
        for n in names:
            r = _child(["--run", n, "--samples", str(samples)], _env_for(n))
            runs[n].append(r)
            print(f"{_row(n, r)}{f'  [run {rep + 1}]' if a.repeat > 1 else ''}")
            if len(r["device_rates"]) > 1:
                for dn, blocks_per_s in r["device_rates"]:
                    print(f"{'':<9}   {dn}: {blocks_per_s:.0f} blocks/s")
    results = {n: max(rs, key=lambda r: r["samples_per_second"]) for n, rs in runs.items()}
    if a.repeat > 1:
        print(f"\nbest of {a.repeat} runs:")
        print(header)
        for n, r in results.items():
            print(_row(n, r))
    estimates = {r["estimate"] for rs in runs.values() for r in rs}
    print(f"\nsame estimate in every configuration (bit-identical sums): {len(estimates) == 1}")

    def ratio(x: str, y: str) -> float | None:
        if x in results and y in results:
            return results[x]["samples_per_second"] / results[y]["samples_per_second"]
        return None

    print("\nscaling (speed-up; efficiency = speed-up / 2, the ideal being 2x):")
    scaling = {}
    for label, x, y, goal in (
        ("two sub-devices vs one sub-device", "sub2", "sub1", 1.8),
        ("two sub-devices vs one core (the honest baseline on PoCL)", "sub2", "one-core", 1.8),
        ("two sub-devices vs one whole device (same cores)", "sub2", "device", None),
        ("two Dask workers vs one Dask worker", "dask2", "dask1", 1.7),
    ):
        s = ratio(x, y)
        if s is None:
            continue
        scaling[f"{x}/{y}"] = s
        tail = f"  (goal >= {goal}x: {'met' if s >= goal else 'NOT met'})" if goal else ""
        print(f"  {label:<58} {s:5.2f}x  efficiency {100 * s / 2:5.1f}%{tail}")

    over = _child(["--overhead", "--overhead-chunks", str(a.overhead_chunks)], {})
    print("\nscheduling overhead per chunk (null job, one block per chunk):")
    print(f"  one device, run_one_device         {1e6 * over['single_device_s_per_chunk']:8.1f} us")
    print(f"  two sub-devices, run_devices       {1e6 * over['multi_device_s_per_chunk']:8.1f} us")
    if "dask_s_per_task" in over:
        print(f"  Dask task round trip, 2 workers    {1e3 * over['dask_s_per_task']:8.2f} ms")
    load1 = os.getloadavg()
    print(f"\nload average after {load1[0]:.2f}; total {time.time() - t_start:.0f} s")
    if a.json:
        Path(a.json).write_text(json.dumps({"samples": samples, "results": results, "runs": runs, "scaling": scaling,
                                            "overhead": over, "load": [load0, load1]}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
