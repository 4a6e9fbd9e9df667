"""`vfrs plot` on any run (issue 30, item 7): it draws what the history holds and says what it
skipped and why; a damaged history.npz is a one-line error; the contact state at the peak force
is recorded when it happens (contact_peak.npz), survives a stop and resume bit for bit; equal
and opposite contact forces are drawn so that both are seen."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.cli import main

EXAMPLES = Path(__file__).parent.parent / "examples"


@pytest.fixture(scope="module")
def cantilever(tmp_path_factory):
    """The shipped cantilever example (no flow, no contact), 40 steps, through the CLI."""
    out = tmp_path_factory.mktemp("cantilever") / "out"
    assert main(["run", str(EXAMPLES / "cantilever.toml"), "-o", str(out), "--no-progress",
                 "--set", "time.end=0.02"]) == 0
    return out


def test_plot_of_a_run_without_flow_or_contact_draws_what_it_has_and_says_what_it_skipped(cantilever, capsys):
    capsys.readouterr()
    assert main(["plot", str(cantilever)]) == 0
    printed = capsys.readouterr().out.splitlines()
    wrote = [line[len("wrote "):] for line in printed if line.startswith("wrote ")]
    assert {os.path.basename(p) for p in wrote} == {"probes.png", "energy.png", "reactions.png"}, printed
    for p in wrote:
        assert os.path.getsize(p) > 10_000
    assert "skipped contact force: the run has no contact" in printed
    assert "skipped glottal area and flow: the run has no [flow]" in printed
    assert sorted(os.listdir(cantilever / "plots")) == ["energy.png", "probes.png", "reactions.png"]


def _damaged_copy(src, dst, how):
    import shutil

    shutil.copytree(src, dst)
    path = dst / "history.npz"
    if how == "truncated":
        with open(path, "r+b") as fh:
            fh.truncate(os.path.getsize(path) // 2)
    else:
        path.write_bytes(b"")
    return path


@pytest.mark.parametrize("how", ["truncated", "empty"])
def test_a_damaged_history_is_a_one_line_error_naming_the_file_and_what_to_do(cantilever, tmp_path, capsys, how):
    out = tmp_path / "out"
    path = _damaged_copy(cantilever, out, how)
    capsys.readouterr()
    assert main(["plot", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vfrs: error: "), err
    assert str(path) in err and "damaged or incomplete" in err
    assert "--overwrite" in err and f"--resume {out}" in err


def test_the_command_exits_non_zero_without_a_traceback_on_a_truncated_history(cantilever, tmp_path):
    out = tmp_path / "out"
    _damaged_copy(cantilever, out, "truncated")
    done = subprocess.run([sys.executable, "-m", "vfrs", "plot", str(out)], capture_output=True, text=True)
    assert done.returncode != 0
    assert "Traceback" not in done.stderr and "BadZipFile" in done.stderr  # (the reason, inside the one line)
    assert done.stderr.count("\n") == 1 and "history.npz: damaged or incomplete" in done.stderr


def _forces(kind):
    t = np.linspace(0.0, 0.01, 200)
    F = np.zeros((len(t), 3))
    F[:, 0] = np.maximum(0.0, np.sin(2 * np.pi * 200 * t)) * 0.02
    F[:, 1] = 1e-3 * F[:, 0]
    if kind == "equal and opposite":
        return t, {"right": F, "left": -F * (1 + 1e-15)}  # round-off apart
    return t, {"right": F, "left": -0.9 * F}


def test_equal_and_opposite_forces_are_one_line_labelled_as_both():
    from vfrs.plot import contact_force_figure, require_matplotlib

    plt = require_matplotlib()
    t, forces = _forces("equal and opposite")
    fig = contact_force_figure(plt, t, forces, "test")
    top, bottom = fig.axes[0], fig.axes[1]
    (line,) = top.get_lines()  # the lengths coincide: one line, not one hidden under the other
    assert "right = left" in line.get_label() and "equal and opposite" in line.get_label()
    assert [x.get_text() for x in top.get_legend().get_texts()] == [line.get_label()]
    a, b = bottom.get_lines()  # F_x: mirror images, both drawn
    assert np.allclose(a.get_ydata(), -b.get_ydata()) and a.get_linestyle() != b.get_linestyle()
    plt.close(fig)


def test_forces_that_differ_are_drawn_in_different_line_styles():
    from vfrs.plot import contact_force_figure, require_matplotlib

    plt = require_matplotlib()
    t, forces = _forces("different")
    fig = contact_force_figure(plt, t, forces, "test")
    for ax in fig.axes[:2]:
        a, b = ax.get_lines()
        assert (a.get_label(), b.get_label()) == ("right", "left")
        assert a.get_linestyle() != b.get_linestyle() and a.get_linewidth() != b.get_linewidth()
    plt.close(fig)


def _blocks_scene():
    sys.path.insert(0, str(Path(__file__).parent))
    from test_architecture import blocks

    d = blocks({"method": "augmented_lagrange", "kappa": 1e9, "detection": "bvh"})
    d["time"] = {"mode": "dynamic", "step": 2e-3, "end": 0.06}
    d["output"] = {"energy": True, "every": 5}
    return vfrs.Scene.from_dict(d)


def peak_row(history, bodies):
    """The history row of the largest total contact force (the first, on a tie)."""
    from vfrs.enforcement.record import force_length

    return int(np.argmax(np.max([force_length(history[f"contact_force.{b}"]) for b in bodies], axis=0)))


def assert_peak_map_is_the_histories(out, bodies):
    """contact_peak.npz is the state of the history's peak-force step: same row, time and
    force, and its largest nodal pressure is that row's contact_pressure_max (not a tolerance:
    the same numbers)."""
    from vfrs.enforcement.record import force_length

    with np.load(out / "history.npz", allow_pickle=False) as z:
        h = {k: z[k] for k in z.files}
    with np.load(out / "contact_peak.npz", allow_pickle=False) as z:
        peak = {k: z[k] for k in z.files}
    k = peak_row(h, bodies)
    assert int(peak["row"]) == k
    assert float(peak["t"]) == h["t"][k]
    assert float(peak["force"]) == max(float(force_length(h[f"contact_force.{b}"][k])) for b in bodies) > 0
    assert float(peak["pressure"].max()) == h["contact_pressure_max"][k] > 0
    assert peak["positions"].shape == (len(peak["pressure"]), 3)
    return peak


def test_the_peak_map_is_recorded_at_the_peak_and_resumes_bit_identically(tmp_path):
    """Two blocks pressed together, dynamic: the largest force is at row 2 (of 31); a run
    stopped at step 6 and resumed must keep it (a recorder that forgot it would record the
    next largest, later) and write the same contact_peak.npz as one run."""
    from test_checkpoint import _Terminate

    from vfrs.checkpoint import RunStopped
    from vfrs.effects import EFFECTS

    scene = _blocks_scene()
    ref = vfrs.run(scene, out=tmp_path / "ref", progress=False)
    A = assert_peak_map_is_the_histories(tmp_path / "ref", ["low", "up"])
    stop_at = int(A["row"]) + 4
    assert stop_at < len(ref.t) - 1
    effects = [EFFECTS[n](p) for n, p in scene.effects.items()] + [_Terminate(stop_at)]
    with pytest.raises(RunStopped):
        vfrs.run(scene, out=tmp_path / "run", progress=False, effects=effects, checkpoint_seconds=None)
    assert not (tmp_path / "run" / "contact_peak.npz").exists()  # written when the run completes
    vfrs.resume(tmp_path / "run", progress=False)
    B = assert_peak_map_is_the_histories(tmp_path / "run", ["low", "up"])
    assert A.keys() == B.keys()
    for k in A:
        assert np.array_equal(A[k], B[k]), k
    assert "contact_peak.npz" in (tmp_path / "run" / "manifest.json").read_text()


def test_the_recorders_state_is_plain_data():
    """The peak map in a checkpoint is arrays, numbers and strings (no objects to pickle)."""
    scene = _blocks_scene()
    from vfrs.effects import EFFECTS

    contact = EFFECTS["contact"](scene.effects["contact"])
    vfrs.run(scene, progress=False, effects=[contact])
    state = contact.recorder.state()
    peak = {k: v for k, v in state.items() if k.startswith("peak_")}
    assert set(peak) == {"peak_force", "peak_t", "peak_row", "peak_body", "peak_pressure", "peak_positions"}
    for k, v in peak.items():
        assert type(v) in (float, int, str, np.ndarray), (k, type(v))
    assert peak["peak_row"] == 2 and peak["peak_body"] in ("low", "up")


@pytest.mark.parametrize("how", ["truncated", "empty"])
def test_analysis_load_of_a_damaged_history_is_one_vfrs_error(cantilever, tmp_path, how):
    """vfrs.analysis.load (what sweeps and scripts use) answers a damaged history.npz with the
    same one-line VfrsError as `vfrs plot` (was zipfile.BadZipFile from numpy)."""
    from vfrs.analysis import load
    from vfrs.errors import VfrsError

    out = tmp_path / "run"
    path = _damaged_copy(cantilever, out, how)
    with pytest.raises(VfrsError, match="damaged or incomplete") as e:
        load(out)
    assert str(path) in str(e.value) and "\n" not in str(e.value)
