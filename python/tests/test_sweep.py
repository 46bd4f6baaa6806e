"""Sweeps from Python against `nekosim sweep --out`: the runs and summary tables, here and
on a Dask cluster, are the CSVs the command line writes for the same sweep, byte for byte
and as DataFrames; a bad sweep raises at its location.

Run by tests/integration/python_package.rs with NEKOSIM_BIN naming the command line.
"""

import os
import subprocess
from pathlib import Path

import pandas as pd
import pytest

import nekosim

ROOT = Path(__file__).resolve().parents[2]
BIN = os.environ.get("NEKOSIM_BIN", str(ROOT / "target" / "debug" / "nekosim"))
SMOKE = ROOT / "examples" / "sweeps" / "smoke.ron"


@pytest.fixture(scope="module")
def cli_tables(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    done = subprocess.run([BIN, "sweep", str(SMOKE), "--out", str(out), "--quiet"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out / "runs.csv", out / "summary.csv"


def same_as_cli(result, cli_tables):
    runs, summary = cli_tables
    assert result.runs_csv == runs.read_text()
    assert result.summary_csv == summary.read_text()
    pd.testing.assert_frame_equal(result.runs, pd.read_csv(runs))
    pd.testing.assert_frame_equal(result.summary, pd.read_csv(summary))
    assert len(result.runs) == 20 and len(result.summary) == 4
    assert result.runs["collisions"].dtype == "int64"
    assert list(result.runs["robots[0].count"].unique()) == [50, 100]


def test_a_sweep_gives_the_command_lines_csvs(cli_tables):
    for jobs in (1, 2):
        same_as_cli(nekosim.sweep(SMOKE, jobs=jobs), cli_tables)


def test_sweep_text_reads_its_scenario_relative_to_base(cli_tables):
    result = nekosim.sweep(SMOKE.read_text(), base=SMOKE.parent)
    same_as_cli(result, cli_tables)
    runs, summary = result
    assert runs is result.runs and summary is result.summary


def test_a_sweep_on_a_dask_client_gives_the_same_tables(cli_tables):
    import distributed
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        same_as_cli(nekosim.sweep(SMOKE, client=client), cli_tables)
        same_as_cli(nekosim.sweep(str(SMOKE), client=client, tasks=3), cli_tables)


def test_a_bad_sweep_raises_at_its_place(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text(SMOKE.read_text().replace('"../scenarios/random_movement.ron"',
                                             f'"{ROOT}/examples/scenarios/random_movement.ron"')
                   .replace("count: 5", "count: 0"))
    with pytest.raises(nekosim.ScenarioError) as e:
        nekosim.sweep(bad)
    assert e.value.file == str(bad) and e.value.line == 5
    assert str(e.value).startswith(f"{bad}:5:")
