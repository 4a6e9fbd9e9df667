"""Re-run some runs of a committed sweep table and put their new rows (and summary.json files)
in place of the old ones, leaving every other row as committed.

For a change of the summary that moves the numbers of some runs only (issue 43: the extremes
over whole glottal cycles and the cycle detection's sub-pulse rule), when which runs it moves
can be told from the committed files (examples/validation_results: the extremes' times against
the window and the cycles' lengths); the rows left are what the new code gives too.

    python examples/rerun_rows.py SWEEP.toml TABLE.csv SUMMARIES_DIR WORK_DIR ID [ID ...]

e.g. ``python examples/rerun_rows.py examples/sweeps/validation_pressure.toml
examples/validation_results/summary.csv examples/validation_results/summaries/medium
/tmp/rerun_medium e2033cf0289d``. Runs one at a time in this process (as ``vfrs sweep
--serial``), into ``WORK_DIR/runs/<id>``; prints which columns of each row changed.
"""

from __future__ import annotations

import csv
import io
import os
import shutil
import sys

from vfrs.studies.sweep import load_sweep, run_task


#: The columns a re-run changes whatever the code (its clocks, memory and build).
BOOKKEEPING = ("wall_time [s]", "peak_rss [MB]", "vfrs code", "run.wall_time [s]")


def cell(value) -> str:
    """A value as vfrs.studies.sweep.write_table writes it into the CSV."""
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else str(value)


def rerun(sweep_path: str, table: str, summaries: str, work: str, ids: list) -> None:
    sweep = load_sweep(sweep_path)
    with open(table, newline="") as fh:
        text = fh.read()
    rows = list(csv.reader(io.StringIO(text)))
    header, body = rows[0], rows[1:]
    runs_dir = os.path.join(work, "runs")
    os.makedirs(runs_dir, exist_ok=True)
    for run_id in ids:
        spec = next(r for r in sweep.runs if r["id"] == run_id)
        row = run_task({**spec, "runs": runs_dir, "source": f"{sweep.source} run {spec['index']}",
                        "derived": sweep.derived, "attempt": 1, "single_thread": False})
        row["skipped"] = False
        extra = [k for k in row if k not in header]
        if extra:
            raise SystemExit(f"{run_id}: columns the table lacks: {extra}")
        k = next(i for i, r in enumerate(body) if r[0] == run_id)
        new = [cell(row.get(name)) for name in header]
        changed = [(name, old, now) for name, old, now in zip(header, body[k], new) if old != now]
        print(f"{run_id}: {row['status']}, {len(changed)} cells changed:")
        for name, old, now in changed:
            print(f"  {name}: {old} -> {now}")
        if all(name in BOOKKEEPING for name, _, _ in changed):
            print(f"  {run_id}: the same numbers: its committed row and summary stay")
            continue
        body[k] = new
        src = os.path.join(runs_dir, run_id, "summary.json")
        if os.path.exists(src):
            shutil.copyfile(src, os.path.join(summaries, f"{run_id}.json"))
    out = io.StringIO()
    w = csv.writer(out)
    w.writerow(header)
    w.writerows(body)
    with open(table, "w", newline="") as fh:
        fh.write(out.getvalue())


if __name__ == "__main__":
    if len(sys.argv) < 6:
        raise SystemExit(__doc__)
    rerun(sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5:])
