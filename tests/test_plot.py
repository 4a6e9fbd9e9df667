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
    from vfrs.enforcement.figures import contact_force_figure
    from vfrs.figures import require_matplotlib

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
    from vfrs.enforcement.figures import contact_force_figure
    from vfrs.figures import require_matplotlib

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
    """vfrs.output.load (what sweeps and scripts use) answers a damaged history.npz with the
    same one-line VfrsError as `vfrs plot` (was zipfile.BadZipFile from numpy)."""
    from vfrs.output import load
    from vfrs.errors import VfrsError

    out = tmp_path / "run"
    path = _damaged_copy(cantilever, out, how)
    with pytest.raises(VfrsError, match="damaged or incomplete") as e:
        load(out)
    assert str(path) in str(e.value) and "\n" not in str(e.value)


# --- The figures a person looks at (issue 43, item 11) -------------------------------------------

#: The standard figures of the main job (all but the voice's, which need [acoustics]).
MAIN_JOB_FIGURES = {"glottal_area_flow.png", "contact_force.png", "contact_pressure.png", "pressure_map.png",
                    "probes.png", "energy.png", "reactions.png"}

#: The main job's f0 and open quotient as its summary holds them (medium mesh, 50 ms, at f0c97a9,
#: with the error bars of its committed study): with their per-cycle values the glottal figure's
#: second title line was cut at both ends (without the error bars, at 756dc2d: 1071 px on a
#: 960 px canvas).
STUDY = "the converge study in examples/converge_results/m5_collision (step part + mesh part, GCI with Fs = 1.25)"
MAIN_JOB_PHONATION = {
    "f0": {"value": 181.71928894531933, "unit": "Hz", "what": "fundamental frequency (glottal area)",
           "per_cycle": [219.4237825335123, 162.25372342850565, 172.75926626500748], "over": "window",
           "error": {"relative": 0.2672577002104755, "bound": False, "source": STUDY}},
    "open_quotient": {"value": 0.7872931129666378, "unit": "1", "what": "open quotient (area > min + 0.1 range)",
                      "per_cycle": [1.0, 0.6911340628671999, 0.6707452760327139], "over": "window",
                      "error": {"relative": 0.12546614337785247, "bound": False, "source": STUDY}}}


@pytest.fixture(scope="module")
def short_collision(tmp_path_factory):
    """The main job (examples/m5_collision.toml) on the coarse mesh, 5 ms (the folds first
    touch at 2.4 ms), through the CLI."""
    out = tmp_path_factory.mktemp("m5_short") / "out"
    assert main(["run", str(EXAMPLES / "m5_collision.toml"), "-o", str(out), "--no-progress",
                 "--set", "bodies[0].mesh.resolution='coarse'", "--set", "bodies[1].mesh.resolution='coarse'",
                 "--set", "time.end=0.005"]) == 0
    return out


@pytest.fixture
def drawn(monkeypatch, tmp_path):
    """drawn(out) -> ({figure name: the open matplotlib figure}, skipped): what `vfrs plot out`
    draws, kept open instead of saved (at the dpi it is saved with); closed after the test."""
    from vfrs import plot
    from vfrs.figures import Figures

    figures: dict = {}

    def keep(self, fig, name):
        fig.set_dpi(120)  # what Figures.save writes with
        figures[name] = fig

    monkeypatch.setattr(Figures, "save", keep)
    yield lambda out: (figures, plot.draw_run(out, tmp_path / "plots")[1])
    import matplotlib.pyplot as plt

    for fig in figures.values():
        plt.close(fig)


def text_off_canvas(fig) -> list:
    """The texts of ``fig`` drawn (partly) outside its canvas: [(text, its extent in px)]. Tick
    labels count only where drawn (an axis' tight box holds the ticks inside its view)."""
    from matplotlib.text import Text

    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    box = fig.bbox

    def outside(b):
        return b.x0 < box.x0 - 1 or b.y0 < box.y0 - 1 or b.x1 > box.x1 + 1 or b.y1 > box.y1 + 1

    ticks, off = set(), []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                ticks.update((id(tick.label1), id(tick.label2)))
            b = axis.get_tightbbox(r)
            if b is not None and outside(b):
                off.append((f"ticks of {axis.get_label_text()!r}", tuple(np.round(b.extents))))
    for t in fig.findobj(Text):
        if id(t) not in ticks and t.get_visible() and t.get_text():
            b = t.get_window_extent(r)
            if outside(b):
                off.append((t.get_text(), tuple(np.round(b.extents))))
    return off


def _with_main_job_phonation(src, dst):
    """A copy of the run ``src`` whose summary holds the main job's f0 and open quotient."""
    import json
    import shutil

    shutil.copytree(src, dst)
    summary = json.loads((dst / "summary.json").read_text())
    summary["phonation"].update(MAIN_JOB_PHONATION)
    (dst / "summary.json").write_text(json.dumps(summary))
    return dst


def test_every_figure_of_the_main_job_keeps_its_text_on_the_canvas(short_collision, drawn, tmp_path):
    """No title, label, tick label or legend of any figure of the main job leaves the canvas,
    with the main job's per-cycle f0 and open quotient in the summary (the shortened run has
    no whole cycle): the glottal figure's second title line was cut at both ends (1071 px on 960)."""
    figures, skipped = drawn(_with_main_job_phonation(short_collision, tmp_path / "run"))
    assert set(figures) == MAIN_JOB_FIGURES and skipped == [("voice", "the run has no [acoustics]")]
    for name, fig in figures.items():
        assert text_off_canvas(fig) == [], name


def test_the_glottal_figure_says_what_the_grey_window_is(short_collision, drawn):
    """The grey span is the summary's analysis window: a legend entry says so, with its times."""
    import vfrs

    figures, _ = drawn(short_collision)
    w = vfrs.load(short_collision).summary.window
    labels = [t.get_text() for leg in figures["glottal_area_flow.png"].legends for t in leg.get_texts()]
    window = [s for s in labels if s.startswith("analysis window")]
    assert len(window) == 1 and f"{w['start'] * 1e3:.4g}-{w['end'] * 1e3:.4g} ms" in window[0], labels
    assert any("in contact" in s for s in labels), labels


def test_the_measured_band_is_behind_the_sensor_pressure(short_collision, drawn):
    """contact_pressure.png draws the history's sensor pressure (contact_pressure_sensor, what
    the summary's peak_sensor_pressure is the largest of, the one to compare with measurements)
    in front of the measured 0.5-5 kPa band; the nodal maximum stays, labelled as one node's."""
    import vfrs

    h = vfrs.output.load(short_collision).history
    figures, _ = drawn(short_collision)
    (ax,) = figures["contact_pressure.png"].axes
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    sensor = [ln for label, ln in lines.items() if "sensor" in label]
    assert len(sensor) == 1, list(lines)
    assert np.array_equal(sensor[0].get_ydata(), np.asarray(h["contact_pressure_sensor"]) * 1e-3)
    assert np.asarray(h["contact_pressure_sensor"]).max() > 0  # the folds touched
    (band,) = [p for p in ax.patches if "Jiang & Titze" in p.get_label()]
    assert "0.5-5 kPa" in band.get_label() and "compare the sensor" in band.get_label()
    assert band.get_zorder() < sensor[0].get_zorder()
    nodal = [ln for label, ln in lines.items() if label.startswith("largest nodal pressure")]
    assert len(nodal) == 1 and np.array_equal(nodal[0].get_ydata(), np.asarray(h["contact_pressure_max"]) * 1e-3)


def test_the_energy_figure_is_in_uJ_and_draws_the_balance(short_collision, drawn):
    """Energies in uJ (the main job's are 1e-5 to 1e-4 J), and a second panel with the remainder
    input work - (kinetic + elastic + dissipated + contact), each its change since the first
    record, computed here from the history:
    HHT alpha = -0.3 dissipates by itself, so it is >= 0 (to round-off) and small (measured at
    5 ms: 0.0068 uJ of 97.8 uJ of flow work, lowest -4e-7 uJ; the medium 50 ms main job: 0.23
    uJ of 98.3)."""
    import vfrs

    h = vfrs.output.load(short_collision).history
    figures, _ = drawn(short_collision)
    top, bottom = figures["energy.png"].axes
    assert top.get_ylabel() == "energy (uJ)" and bottom.get_ylabel() == "remainder (uJ)"
    W, K, E, D, C = (h[k] - h[k][0] for k in ("external_work", "kinetic_energy", "elastic_energy", "damping_work",
                                               "contact_work"))
    remainder = (W - K - E - D + C) * 1e6  # contact_work: the work contact did on the folds
    (line,) = [ln for ln in bottom.get_lines() if ln.get_label().startswith("remainder")]
    assert np.allclose(line.get_ydata(), remainder, rtol=0, atol=1e-9 * np.abs(W).max() * 1e6)
    assert "numerical dissipation" in line.get_label()
    assert remainder.min() > -1e-6 * W.max() * 1e6 and 0 < remainder[-1] < 1e-2 * W.max() * 1e6
    labels = [t.get_text() for leg in figures["energy.png"].legends for t in leg.get_texts()]
    assert {"kinetic", "elastic", "dissipated by damping", "input work (the loads')"} <= set(labels), labels


def legends_over_curves(fig) -> list:
    """[(legend entry, number of data points it covers)]: the points of the figure's lines that
    are drawn (inside their axes) and fall inside a legend's box."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    legends = fig.legends + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    covered = []
    for leg in legends:
        box = leg.get_window_extent(r)
        n = 0
        for ax in fig.axes:
            for line in ax.get_lines():
                xy = line.get_transform().transform(np.column_stack([line.get_xdata(), line.get_ydata()]))
                inside_axes = ax.bbox.contains_points(xy) if hasattr(ax.bbox, "contains_points") else (
                    (xy[:, 0] >= ax.bbox.x0) & (xy[:, 0] <= ax.bbox.x1) & (xy[:, 1] >= ax.bbox.y0)
                    & (xy[:, 1] <= ax.bbox.y1))
                under = (xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
                n += int(np.count_nonzero(under & inside_axes))
        if n:
            covered.append((leg.get_texts()[0].get_text(), n))
    return covered


@pytest.mark.parametrize("name", ["reactions.png", "probes.png"])
def test_no_legend_covers_a_curve(short_collision, drawn, name):
    """The legends of the long series stand outside the axes: none covers a drawn point of any
    curve (reactions.png had one legend per support inside each panel, over the curves; probes.png
    one per probe). (The figures with more curves put theirs below the axes from the start.)"""
    figures, _ = drawn(short_collision)
    assert legends_over_curves(figures[name]) == []


def _flat_surface(x, height, loaded):
    """A flat rectangle in the plane x = ``x``: z 0-14 mm, y from -``height`` to 0 mm, 15 x 9
    nodes; pressure 1 kPa on the nodes with -y inside ``loaded`` (mm) and 5 mm < z < 9 mm."""
    z, y = np.meshgrid(np.linspace(0, 14e-3, 15), np.linspace(-height, 0, 9))
    X = np.column_stack([np.full(z.size, x), y.ravel(), z.ravel()])
    k = np.arange(z.size).reshape(z.shape)
    a, b, c, d = k[:-1, :-1].ravel(), k[:-1, 1:].ravel(), k[1:, 1:].ravel(), k[1:, :-1].ravel()
    tri = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    p = np.where((-X[:, 1] >= loaded[0] * 1e-3) & (-X[:, 1] <= loaded[1] * 1e-3) & (X[:, 2] > 5e-3)
                 & (X[:, 2] < 9e-3), 1e3, 0.0)
    return X, tri, p


def test_the_pressure_map_panels_are_equally_wide(monkeypatch, tmp_path):
    """The two bodies' maps (one shared colour bar) have the same width and height on the canvas,
    also when their contact zones differ in height: with equal aspect, the panel whose zone was
    taller was narrower (the main job's, 19.2 ms: 730 px against 860)."""
    from vfrs.enforcement.figures import draw_maps
    from vfrs.figures import Figures, require_matplotlib

    figures: dict = {}
    monkeypatch.setattr(Figures, "save", lambda self, fig, name: figures.setdefault(name, fig))
    plt = require_matplotlib()
    maps = [(b, *_flat_surface(x, 5e-3, zone)) for b, x, zone in (("right", 1e-4, (1.0, 1.5)),
                                                                  ("left", -1e-4, (1.0, 3.0)))]
    draw_maps(Figures(plt, str(tmp_path)), maps, "two flat surfaces", "at a made-up step")
    fig = figures["pressure_map.png"]
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert len(panels) == 2 and len(fig.axes) == 3
    (w1, h1), (w2, h2) = [(ax.get_window_extent(r).width, ax.get_window_extent(r).height) for ax in panels]
    plt.close(fig)
    assert abs(w1 - w2) <= 1 and abs(h1 - h2) <= 1, (w1, w2, h1, h2)
