"""Run a nekosim parameter sweep as shards on a Dask cluster, then merge them.

Each shard is one Dask task that runs, on a worker,

    NEKOSIM sweep SWEEP --shard I/N --out TMPDIR [--jobs J] --quiet

in a fresh temporary directory and sends the shard's files back to the client,
so the outputs need no shared file system. The client writes shard I to
OUT/shards/I/ and runs `NEKOSIM sweep merge OUT/shards/0 ... --out OUT`, which
writes exactly the files the unsharded `nekosim sweep SWEEP --out OUT` writes.

Usage (Python 3.11+, `pip install -r tests/sweep/requirements.txt`):

    python examples/sweeps/dask_sweep.py SWEEP.ron --out DIR --shards N
        [--scheduler tcp://HOST:8786] [--workers W] [--jobs J]
        [--nekosim PATH] [--retries R]

Without --scheduler it starts a LocalCluster of W worker processes (default 2),
one thread each. It prints merge's one-line summary and exits with merge's
code: 0 all runs passed, 1 some run failed a check or errored (the results are
still complete), 2 bad input (nekosim's message is printed); 3 if a shard could
not be run for another reason.

Workers run nekosim with the client's working directory as theirs and with the
sweep path exactly as given (it is recorded in the outputs), so on a real
cluster the sweep file, the scenarios it names and the nekosim binary must be
at the same paths on every node (for example a shared home directory).

On an HPC machine, start the workers through the batch system with
dask-jobqueue and pass the scheduler's address, or call sweep() yourself:

    import dask
    from dask_jobqueue import SLURMCluster
    from distributed import Client
    import dask_sweep

    dask.config.set({"distributed.scheduler.allowed-failures": 10})
    cluster = SLURMCluster(cores=32, processes=1, memory="16GB",
                           walltime="02:00:00", queue="normal")
    cluster.scale(jobs=8)  # 8 nodes, one worker (one shard at a time) each
    with Client(cluster) as client:
        code = dask_sweep.sweep("sweeps/big.ron", "out/big", 64, client,
                                nekosim="/home/me/bin/nekosim", jobs=32)
    raise SystemExit(code)

A worker that dies mid-shard (node lost, job preempted) makes the scheduler
run that shard again elsewhere, up to `distributed.scheduler.allowed-failures`
times; that setting belongs to the scheduler, so with --scheduler set it where
the scheduler starts (DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES=10).
A shard whose nekosim exits with anything but 0 or 1 raises on the worker and
is retried --retries times.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ALLOWED_FAILURES = 10


class ShardFailed(RuntimeError):
    """nekosim exited with something other than 0 or 1 for one shard."""

    def __init__(self, message: str, returncode: int):
        super().__init__(message)
        self.returncode = returncode

    def __reduce__(self):
        return (type(self), (self.args[0], self.returncode))


def run_shard(nekosim: str, sweep_path: str, index: int, count: int,
              jobs: int | None, cwd: str) -> dict[str, bytes]:
    """Run shard INDEX/COUNT on this worker; return its files by relative name."""
    with tempfile.TemporaryDirectory(prefix=f"nekosim-shard-{index}-of-{count}-") as tmp:
        cmd = [nekosim, "sweep", sweep_path, "--shard", f"{index}/{count}", "--out", tmp]
        if jobs is not None:
            cmd += ["--jobs", str(jobs)]
        cmd.append("--quiet")
        proc = subprocess.run(cmd, cwd=cwd, stdin=subprocess.DEVNULL,
                              capture_output=True, text=True)
        if proc.returncode not in (0, 1):
            stderr = proc.stderr.strip() or "(no output on stderr)"
            raise ShardFailed(f"shard {index}/{count}: `{' '.join(cmd)}` exited with "
                              f"{proc.returncode}: {stderr}", proc.returncode)
        root = Path(tmp)
        return {p.relative_to(root).as_posix(): p.read_bytes()
                for p in sorted(root.rglob("*")) if p.is_file()}


def _nekosim_path(nekosim: str) -> str:
    # A relative path with a slash is made absolute; a bare name is looked up on
    # each machine's PATH.
    return os.path.abspath(nekosim) if os.sep in nekosim else nekosim


def sweep(sweep_path: str, out: str | os.PathLike, shards: int, client,
          nekosim: str = "nekosim", jobs: int | None = None, retries: int = 2,
          quiet: bool = False) -> int:
    """Run SWEEP in SHARDS Dask tasks on CLIENT and merge into OUT.

    Returns merge's exit code (0 all passed, 1 some run failed, 2 refused);
    merge prints its one-line summary unless QUIET.
    Raises a shard's error if it could not be run: ShardFailed when nekosim
    exited with neither 0 nor 1, KilledWorker when its workers kept dying.
    """
    if __name__ != "__main__":
        # Imported (by a test or your own script), run_shard is sent by reference
        # to this module: put it on the workers' path, present and future ones.
        from distributed.diagnostics.plugin import UploadFile
        client.register_plugin(UploadFile(__file__, load=False), name=f"upload-{__name__}")
    nekosim = _nekosim_path(nekosim)
    out = Path(out)
    futures = [
        client.submit(run_shard, nekosim, str(sweep_path), i, shards, jobs, os.getcwd(),
                      key=f"nekosim-shard-{i}-of-{shards}", pure=False, retries=retries)
        for i in range(shards)
    ]
    shard_dirs = [out / "shards" / str(i) for i in range(shards)]
    try:
        results = client.gather(futures)
    finally:
        client.cancel(futures)  # forget the keys, and stop the other shards on failure
    for shard_dir, files in zip(shard_dirs, results):
        shutil.rmtree(shard_dir, ignore_errors=True)
        for name, data in files.items():
            path = shard_dir / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
    merge = [nekosim, "sweep", "merge", *map(str, shard_dirs), "--out", str(out)]
    return subprocess.run(merge, stdin=subprocess.DEVNULL,
                          stdout=subprocess.DEVNULL if quiet else None).returncode


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", help="the sweep file, passed as given to every shard")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--shards", type=int, required=True, help="number of shards (tasks)")
    parser.add_argument("--scheduler", help="address of a running scheduler, tcp://HOST:8786")
    parser.add_argument("--workers", type=int, default=2,
                        help="worker processes of the local cluster (default 2)")
    parser.add_argument("--jobs", type=int,
                        help="--jobs for each shard (default: cores / workers with the "
                             "local cluster, nekosim's own default with --scheduler)")
    parser.add_argument("--nekosim", default="nekosim", help="the nekosim binary (default: on PATH)")
    parser.add_argument("--retries", type=int, default=2,
                        help="times a failing shard is run again (default 2)")
    args = parser.parse_args(argv)
    if args.shards < 1 or args.workers < 1 or (args.jobs is not None and args.jobs < 1):
        parser.error("--shards, --workers and --jobs must be at least 1")

    import dask
    from distributed import Client, LocalCluster

    dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES})
    jobs = args.jobs
    if args.scheduler:
        client, cluster = Client(args.scheduler), None
    else:
        if jobs is None:
            jobs = max(1, (os.cpu_count() or 1) // args.workers)
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True)
        client = Client(cluster)
    try:
        code = sweep(args.sweep, args.out, args.shards, client,
                     nekosim=args.nekosim, jobs=jobs, retries=args.retries)
    except Exception as err:  # a shard nekosim refused or that crashed, a lost scheduler...
        print(f"dask_sweep: {type(err).__name__}: {err}", file=sys.stderr)
        return 2 if getattr(err, "returncode", None) == 2 else 3
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    # On 0 and 1 merge has printed the summary (runs, failing, errors, where).
    if code not in (0, 1):
        print(f"dask_sweep: merge into {args.out} exited with {code}", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
