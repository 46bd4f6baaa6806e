"""examples/nekosim.ipynb runs: its code cells are executed in order, in one namespace, from
the repository's root, with matplotlib drawing off screen; and what they show is checked."""

import json
from pathlib import Path

import matplotlib

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "examples" / "nekosim.ipynb"


def test_the_notebook_runs(monkeypatch):
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    monkeypatch.chdir(ROOT)
    cells = json.loads(NOTEBOOK.read_text())["cells"]
    code = [("".join(c["source"])) for c in cells if c["cell_type"] == "code"]
    assert len(code) >= 6
    ns = {"__name__": "__main__"}
    for i, src in enumerate(code):
        exec(compile(src, f"{NOTEBOOK.name} cell {i}", "exec"), ns)
    assert len(ns["runs"]) == 20 and len(ns["summary"]) == 4
    assert ns["cog"].summary["events"] > 0
    failing = ns["c"].verdicts[ns["c"].verdicts.verdict == "fails"]
    assert list(failing.property) == ["uniform agreement"]
    assert len(ns["c"].counterexample) == 5
    assert plt.get_fignums(), "the notebook draws its plots"
    plt.close("all")
