"""Check that the Dask launcher gives exactly the unsharded sweep's files.

    python tests/sweep/test_dask.py NEKOSIM SWEEP.ron

(with `pip install -r tests/sweep/requirements.txt`), run from the directory the
sweep path is relative to. It runs

  A. `NEKOSIM sweep SWEEP --out A --jobs 1`, the reference;
  B. examples/sweeps/dask_sweep.py's sweep() with 4 shards on a LocalCluster of
     2 worker processes (1 thread each) into B;
  C. the same into C on a fresh cluster, SIGKILLing one worker process (and the
     nekosim it started) while it runs a shard, so Dask must run it again;

and checks that every file of A is in B and C byte for byte, that they have no
other files but shards/**, and that the exit codes agree. It prints one line
starting `test_dask: ok` and exits 0, or prints what differs and exits 1.
"""

from __future__ import annotations

import difflib
import importlib.util
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

SHARDS = 4
WORKERS = 2
TIMEOUT = 900  # seconds for the whole test; it fails rather than hang
LAUNCHER = Path(__file__).resolve().parents[2] / "examples" / "sweeps" / "dask_sweep.py"


def load_launcher():
    spec = importlib.util.spec_from_file_location("dask_sweep", LAUNCHER)
    module = importlib.util.module_from_spec(spec)
    sys.modules["dask_sweep"] = module
    spec.loader.exec_module(module)
    return module


def files_under(root: Path) -> dict[str, Path]:
    return {p.relative_to(root).as_posix(): p for p in root.rglob("*") if p.is_file()}


def compare(reference: Path, other: Path, label: str) -> list[str]:
    """What differs between REFERENCE and OTHER, ignoring OTHER/shards/**."""
    problems = []
    ref, got = files_under(reference), files_under(other)
    if not ref:
        problems.append(f"{label}: the reference sweep wrote no files")
    for name, path in sorted(ref.items()):
        if name not in got:
            problems.append(f"{label}: {name} is missing")
            continue
        a, b = path.read_bytes(), got[name].read_bytes()
        if a != b:
            problems.append(f"{label}: {name} differs ({len(a)} bytes unsharded, {len(b)} merged)")
            diff = difflib.unified_diff(a.decode(errors="replace").splitlines(),
                                        b.decode(errors="replace").splitlines(),
                                        "unsharded/" + name, "merged/" + name, lineterm="", n=1)
            problems += ["    " + line for line in list(diff)[:20]]
    for name in sorted(set(got) - set(ref)):
        if not name.startswith("shards/"):
            problems.append(f"{label}: extra file {name}")
    return problems


def new_cluster():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=WORKERS, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    return cluster, Client(cluster)


def kill_worker_running_a_shard(pids: dict[str, int], stop: threading.Event, killed: list):
    """Poll until a worker has a `nekosim sweep --shard` child, then SIGKILL both."""
    import psutil

    while not stop.is_set():
        for address, pid in pids.items():
            try:
                children = psutil.Process(pid).children(recursive=True)
                # Command lines read now: once killed, a child is a zombie whose command
                # line can no longer be read.
                running = [args for args in (c.cmdline() for c in children) if "--shard" in args]
            except psutil.Error:
                continue
            if running:
                os.kill(pid, signal.SIGKILL)
                for child in children:  # a dead node takes its processes with it
                    try:
                        child.kill()
                    except psutil.Error:
                        pass
                args = running[0]
                killed.append((address, pid, args[args.index("--shard") + 1]))
                return
        time.sleep(0.05)


def main() -> int:
    if len(sys.argv) != 3:
        print("usage: test_dask.py NEKOSIM SWEEP.ron", file=sys.stderr)
        return 2
    nekosim, sweep_path = os.path.abspath(sys.argv[1]), sys.argv[2]
    watchdog = threading.Timer(TIMEOUT, lambda: (print(f"test_dask: FAIL: timed out after {TIMEOUT} s",
                                                       flush=True), os._exit(1)))
    watchdog.daemon = True
    watchdog.start()

    import dask

    dask.config.set({"distributed.scheduler.allowed-failures": 10})
    launcher = load_launcher()
    problems = []
    timings = {}
    with tempfile.TemporaryDirectory(prefix="test_dask-") as tmp:
        a, b, c = Path(tmp, "A"), Path(tmp, "B"), Path(tmp, "C")
        # The workers (started later) make their shard directories in here, so
        # the one left by the killed worker goes too.
        Path(tmp, "workers").mkdir()
        os.environ["TMPDIR"] = str(Path(tmp, "workers"))

        start = time.monotonic()
        ref = subprocess.run([nekosim, "sweep", sweep_path, "--out", str(a), "--jobs", "1"],
                             stdin=subprocess.DEVNULL, capture_output=True, text=True)
        timings["A"] = time.monotonic() - start
        if ref.returncode not in (0, 1):
            print(f"test_dask: FAIL: `{nekosim} sweep {sweep_path} --out {a} --jobs 1` exited "
                  f"with {ref.returncode}: {ref.stderr.strip()}")
            return 1

        # B: a plain sharded run.
        start = time.monotonic()
        cluster, client = new_cluster()
        timings["cluster start"] = time.monotonic() - start
        try:
            code = launcher.sweep(sweep_path, b, SHARDS, client, nekosim=nekosim, jobs=1,
                                  quiet=True)
        finally:
            client.close()
            cluster.close()
        timings["B"] = time.monotonic() - start
        if code != ref.returncode:
            problems.append(f"B: the launcher returned {code}, the unsharded sweep {ref.returncode}")
        problems += compare(a, b, "B")

        # C: one worker dies while running a shard.
        start = time.monotonic()
        cluster, client = new_cluster()
        stop, killed = threading.Event(), []
        try:
            pids = client.run(os.getpid)
            killer = threading.Thread(target=kill_worker_running_a_shard,
                                      args=(pids, stop, killed), daemon=True)
            killer.start()
            code = launcher.sweep(sweep_path, c, SHARDS, client, nekosim=nekosim, jobs=1,
                                  quiet=True)
        finally:
            stop.set()
            client.close()
            cluster.close()
        timings["C"] = time.monotonic() - start
        if not killed:
            problems.append("C: no worker was seen running a shard, so none was killed "
                            "(is the sweep too short?)")
        if code != ref.returncode:
            problems.append(f"C: the launcher returned {code}, the unsharded sweep {ref.returncode}")
        problems += compare(a, c, "C")

        if problems:
            print("test_dask: FAIL")
            for line in problems:
                print(line)
            return 1
        count = len(files_under(a))
        times = ", ".join(f"{k} {v:.1f} s" for k, v in timings.items())
        print(f"test_dask: ok: {count} files identical in the unsharded run, {SHARDS} shards "
              f"on {WORKERS} workers, and {SHARDS} shards with worker pid {killed[0][1]} "
              f"killed while running shard {killed[0][2]} (exit {ref.returncode}; {times})")
        return 0


if __name__ == "__main__":
    sys.exit(main())
