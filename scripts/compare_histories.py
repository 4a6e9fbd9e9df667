"""Every history array of the example scenes, recorded and compared bit for bit.

A restructuring that claims "no behaviour change" is checked with it: record at the commit
before, record at the commit after, compare.

    python scripts/compare_histories.py record OUT_DIR [--end SECONDS] [--only NAME ...]
    python scripts/compare_histories.py compare DIR_A DIR_B

``record`` runs each ``examples/*.toml`` (no output folder: the arrays are taken from the
returned result) and writes ``OUT_DIR/<scene>.npz`` with every history array and
``OUT_DIR/commit.txt`` with the commit of the working tree (and whether it was clean).
``--end`` shortens a scene's run to at most that many seconds (its ``[time] end`` otherwise;
the 0.2 s voice and the 50 ms main job take minutes between them): what is compared is then
the first ``--end`` seconds, said in the record. ``compare`` exits 1 naming every array that
differs in shape, dtype or any bit (NaNs compared as bits too), and every scene or array
present on one side only.
"""

from __future__ import annotations

import argparse
import pathlib
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def _commit() -> str:
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                           capture_output=True, text=True).stdout.strip()
    return head + (" (with uncommitted changes)" if dirty else "")


def record(out: pathlib.Path, end: float | None, only: list[str]) -> None:
    import vfrs
    from vfrs.scene import Scene, read_toml

    out.mkdir(parents=True, exist_ok=True)
    lines = [f"commit {_commit()}", f"end cap {end} s" if end else "end: each scene's own"]
    for path in sorted(EXAMPLES.glob("*.toml")):
        if only and path.stem not in only:
            continue
        data = read_toml(path)
        if end is not None and data.get("time", {}).get("mode", "dynamic") == "dynamic":
            data.setdefault("time", {})
            data["time"]["end"] = min(float(data["time"].get("end", end)), end)
        scene = Scene.from_dict(data, source=str(path), base_dir=str(path.parent))
        t0 = time.perf_counter()
        res = vfrs.run(scene, progress=False)
        arrays = {k: np.asarray(v) for k, v in res.history.items()}
        np.savez(out / f"{path.stem}.npz", **arrays)
        lines.append(f"{path.stem}: {len(arrays)} arrays, {time.perf_counter() - t0:.1f} s")
        print(lines[-1], flush=True)
    (out / "commit.txt").write_text("\n".join(lines) + "\n")


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind in "fc":
        return a.tobytes() == b.tobytes()
    return bool(np.array_equal(a, b))


def compare(a: pathlib.Path, b: pathlib.Path) -> int:
    bad, n = [], 0
    names = sorted({p.name for p in a.glob("*.npz")} | {p.name for p in b.glob("*.npz")})
    for name in names:
        if not (a / name).exists() or not (b / name).exists():
            bad.append(f"{name}: only in {a if (a / name).exists() else b}")
            continue
        with np.load(a / name) as za, np.load(b / name) as zb:
            for key in sorted(set(za.files) | set(zb.files)):
                n += 1
                if key not in za.files or key not in zb.files:
                    bad.append(f"{name}:{key}: on one side only")
                elif not _same(za[key], zb[key]):
                    bad.append(f"{name}:{key}: differs")
    for line in bad:
        print(line)
    print(f"{len(names)} scenes, {n} arrays: {len(bad)} differ" if bad else
          f"{len(names)} scenes, {n} arrays: all bit-identical")
    return 1 if bad else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="run the example scenes and store their histories")
    r.add_argument("out", type=pathlib.Path)
    r.add_argument("--end", type=float, default=None, help="cap each dynamic run at this many seconds")
    r.add_argument("--only", nargs="*", default=[], help="scene names (file stems) to run")
    c = sub.add_parser("compare", help="compare two records bit for bit")
    c.add_argument("a", type=pathlib.Path)
    c.add_argument("b", type=pathlib.Path)
    args = ap.parse_args(argv)
    if args.cmd == "record":
        record(args.out, args.end, args.only)
        return 0
    return compare(args.a, args.b)


if __name__ == "__main__":
    sys.exit(main())
