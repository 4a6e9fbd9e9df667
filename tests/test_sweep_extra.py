"""The ``sweep`` extra (issue 44, item 6): dask.distributed and pyarrow come only with
``pip install "vfrs[sweep]"``. The base install imports vfrs and runs a scene without them; a
sweep on dask, or a Parquet table, without them is a one-line error naming the extra. A missing
module is simulated by a ``None`` entry in ``sys.modules`` (what makes ``import`` raise
ImportError)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from vfrs.errors import VfrsError
from vfrs.studies.extra import INSTALL, sweep_extra

ROOT = Path(__file__).resolve().parent.parent
MAIN = (ROOT / "examples" / "m5_collision.toml").as_posix()
EXTRA = ("dask", "distributed", "pyarrow")


def without_extra(monkeypatch):
    for name in EXTRA:
        for loaded in [m for m in sys.modules if m == name or m.startswith(name + ".")]:
            monkeypatch.delitem(sys.modules, loaded)
        monkeypatch.setitem(sys.modules, name, None)


def test_the_base_install_runs_a_scene_without_dask_or_pyarrow(tmp_path):
    """``vfrs run`` in a process where dask, distributed and pyarrow cannot be imported: the
    run completes (the main job, coarse, 1 ms)."""
    code = (f"import sys; sys.modules.update(dict.fromkeys({EXTRA!r})); "
            "from vfrs.cli import main; "
            f"sys.exit(main(['run', {MAIN!r}, '-o', {str(tmp_path / 'out')!r}, '--no-progress', "
            "'--set', 'time.end=0.001', '--set', 'bodies[0].mesh.resolution=\"coarse\"', "
            "'--set', 'bodies[1].mesh.resolution=\"coarse\"']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out" / "summary.json").exists()


@pytest.mark.parametrize("module, named", [("distributed", "dask.distributed"), ("pyarrow.parquet", "pyarrow")])
def test_a_missing_module_of_the_extra_is_one_line_naming_it(monkeypatch, module, named):
    without_extra(monkeypatch)
    with pytest.raises(VfrsError) as e:
        sweep_extra(module, "a sweep")
    message = str(e.value)
    assert "\n" not in message and named in message and INSTALL in message and 'vfrs[sweep]' in message


def test_the_pareto_figure_of_a_parquet_table_without_pyarrow(monkeypatch, tmp_path):
    from vfrs.studies.accuracy import pareto_figure

    without_extra(monkeypatch)
    with pytest.raises(VfrsError, match=r'pyarrow, which the base install leaves out: pip install "vfrs\[sweep\]"'):
        pareto_figure(tmp_path / "accuracy.parquet", "block", tmp_path / "p.png")


def test_a_sweep_without_the_extra_stops_before_any_run(monkeypatch, tmp_path):
    """Without dask.distributed, a sweep not ``--serial`` is a one-line error naming the extra;
    without pyarrow, any sweep (its table): before anything runs or any folder is made."""
    import vfrs
    import vfrs.studies.sweep as sw

    scene = vfrs.Scene.load(str(ROOT / "examples" / "bar_static.toml")).to_dict()
    sweep = sw.Sweep.from_runs("extra test", [({"n": 1}, scene)])
    monkeypatch.setattr(sw.task, "_run_scene", lambda scene, folder: pytest.fail("a run ran"))
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(VfrsError, match=r'^a sweep on dask \(without --serial\) needs dask.distributed, .*: '
                                        r'pip install "vfrs\[sweep\]"$'):
        sw.run_sweep(sweep, tmp_path / "out", workers=1)
    without_extra(monkeypatch)
    with pytest.raises(VfrsError, match=r'^a sweep\'s table \(summary.parquet\) needs pyarrow, .*"vfrs\[sweep\]"$'):
        sw.run_sweep(sweep, tmp_path / "out", serial=True)
    assert not (tmp_path / "out").exists()


def test_the_table_without_pyarrow(monkeypatch, tmp_path):
    from vfrs.studies.sweep import write_table

    without_extra(monkeypatch)
    with pytest.raises(VfrsError, match=r'^writing summary.parquet needs pyarrow, which the base install leaves out: '
                                        r'pip install "vfrs\[sweep\]"$'):
        write_table([{"id": "a"}], str(tmp_path), ["id"])
