"""Writes the small unstructured Gmsh meshes used by tests/test_contact_gmsh.py (and
tests/test_contact_dynamic.py: sphere.msh, sphere_upper.msh, sphere_quarter.msh).

Re-run (from the repository root; needs the gmsh Python API, which is not a vfrs
dependency -- the tests only read the committed .msh files):

    pip install gmsh          # measured with gmsh 4.15.2
    python tests/data/make_meshes.py

The output is deterministic for a given gmsh version: a fixed random seed, one thread, fixed
2-D / 3-D algorithms. Coordinates are in millimetres (scenes read them with
``length_unit = "mm"``); files are Gmsh MSH 4.1 ASCII with only the physical groups saved,
each named surface a physical surface and the solid the physical volume "all".

* ``hemisphere.msh``: solid hemisphere, radius 5, pole at the origin, flat face on top at
  z = 5 (surface "flat"), dome facing down ("curved"). On the dome the element size is 0.25
  within 2 of the pole, growing to 1.5 at 4 from it; the volume is coarser (<= 1.5).
* ``sphere.msh``: ball of radius 5 centred at (0, 0, -5) (its top pole at the origin), surface
  "surface"; size 0.3 on the surface within 1.5 of the top pole (and of the point the
  rotation below turns into the bottom pole), 1.3 elsewhere. ``sphere_upper.msh`` is the same
  mesh rotated by 90 degrees about the x axis and moved up so that its centre is at
  (0, 0, 5 + SPHERE_GAP): its bottom sits SPHERE_GAP above the lower sphere's top pole, and
  the two surface meshes do not match there.
* ``sphere_quarter.msh``: the quarter x >= 0, y >= 0 of the ball of radius 5 centred at
  (0, 0, -5) (top pole at the origin, on both cut planes), graded in the volume, not only on
  the surface: size 0.1 within 1 of the top pole, growing linearly to 1.0 at 4 from it and
  beyond; surfaces "curved" (the sphere), "xsym" (the cut plane x = 0) and "ysym" (y = 0),
  for rollers. 1224 nodes, 5162 tetrahedra. Made for Hertz impact at a contact radius of
  about 0.26 (tests/test_contact_dynamic.py: v = 0.01 m/s, E = 1 MPa): the contact zone and
  the volume below it a few contact radii deep are fine, the rest of the ball coarse.
* ``block_a.msh`` and ``block_b.msh``: 10 x 10 x 5 boxes over [0, 10]^2, block_a at z in
  [-5, 0] (size 1.5, 1.0 on its "top"), block_b at z in [BLOCK_GAP, 5 + BLOCK_GAP] (size 2.0,
  1.5 on its "bottom"); surfaces "bottom", "top", "xmin", "xmax", "ymin", "ymax". The
  contacting faces (block_a "top", block_b "bottom") do not match.

Except in sphere_quarter.msh, the contact zones are refined on the surface only (gmsh
"Restrict" fields), which keeps the tetrahedron count low (< 3000 per file) while the
contact surfaces carry enough nodes for the active set to matter: with the
one-pair-at-a-time active set of vfrs 3caae67, Lagrange does not settle in 100 iterations
on any of the three problems (the defect the tests guard).
"""

from __future__ import annotations

import math
import os

import gmsh

HERE = os.path.dirname(os.path.abspath(__file__))
R = 5.0
SPHERE_GAP = 0.05
BLOCK_GAP = 0.01


def _start(name):
    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.Verbosity", 2)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads1D", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads2D", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads3D", 1)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)  # (gmsh has no General.RandomSeed)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay surfaces
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay volume
    gmsh.option.setNumber("Mesh.Optimize", 1)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    gmsh.model.add(name)


def _name_surfaces(groups, volume):
    for name, tags in groups.items():
        gmsh.model.addPhysicalGroup(2, tags, name=name)
    gmsh.model.addPhysicalGroup(3, [volume], name="all")


def _write(name):
    path = os.path.join(HERE, name)
    gmsh.write(path)
    types, tags, _ = gmsh.model.mesh.getElements(3)
    n_tets = sum(len(t) for t in tags)
    print(f"{name}: {len(gmsh.model.mesh.getNodes()[0])} nodes, {n_tets} tets, {os.path.getsize(path)} bytes")
    return path


def _restricted(field, surfaces):
    """``field`` on the given surfaces (and their curves) only; elsewhere Mesh.MeshSizeMax."""
    f = gmsh.model.mesh.field
    curves = sorted({c for _, c in gmsh.model.getBoundary([(2, s) for s in surfaces], combined=False, oriented=False)})
    r = f.add("Restrict")
    f.setNumber(r, "InField", field)
    f.setNumbers(r, "SurfacesList", surfaces)
    f.setNumbers(r, "CurvesList", curves)
    f.setAsBackgroundMesh(r)
    # Sizes come from the field on the contact surface and MeshSizeMax elsewhere (the
    # volume grades between them), not from the points, the boundary or the curvature.
    for opt in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(opt, 0)


def _threshold(distance, fine, coarse, d_fine, d_coarse):
    """Size ``fine`` up to ``d_fine`` from the MathEval distance expression, ``coarse`` beyond
    ``d_coarse``, linear in between."""
    f = gmsh.model.mesh.field
    e = f.add("MathEval")
    f.setString(e, "F", distance)
    t = f.add("Threshold")
    f.setNumber(t, "InField", e)
    for k, v in (("SizeMin", fine), ("SizeMax", coarse), ("DistMin", d_fine), ("DistMax", d_coarse)):
        f.setNumber(t, k, v)
    return t


def hemisphere():
    _start("hemisphere")
    occ = gmsh.model.occ
    # angle1 = -pi/2, angle2 = 0: the southern half of a sphere centred at (0, 0, R).
    vol = occ.addSphere(0, 0, R, R, angle1=-math.pi / 2, angle2=0.0)
    occ.synchronize()
    flat, curved = [], []
    for _, s in gmsh.model.getBoundary([(3, vol)], oriented=False):
        z = occ.getCenterOfMass(2, s)[2]
        (flat if abs(z - R) < 1e-6 else curved).append(s)
    _name_surfaces({"flat": flat, "curved": curved}, vol)
    # On the dome: 0.25 within 2 of the pole (the contact zone and the ring around it that
    # the contact-free solution penetrates), growing to 1.5 at 4 from it; volume <= 1.5.
    _restricted(_threshold("Sqrt(x^2 + y^2 + z^2)", 0.25, 1.5, 2.0, 4.0), curved)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 1.5)
    gmsh.model.mesh.generate(3)
    _write("hemisphere.msh")
    gmsh.finalize()


def sphere():
    _start("sphere")
    occ = gmsh.model.occ
    vol = occ.addSphere(0, 0, -R, R)
    occ.synchronize()
    surf = [s for _, s in gmsh.model.getBoundary([(3, vol)], oriented=False)]
    _name_surfaces({"surface": surf}, vol)
    # Fine (0.3) within 1.5 of the top pole (0, 0, 0) and of (0, -R, -R), the point the
    # rotation below brings to the upper copy's bottom; 1.3 beyond 3.5.
    dist = f"Min(Sqrt(x^2 + y^2 + z^2), Sqrt(x^2 + (y + {R})^2 + (z + {R})^2))"
    _restricted(_threshold(dist, 0.3, 1.3, 1.5, 3.5), surf)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 1.3)
    gmsh.model.mesh.generate(3)
    _write("sphere.msh")
    # The same mesh, rotated by 90 degrees about x around its centre (0, 0, -R), then moved
    # up by 2 R + SPHERE_GAP: node (x, y, z) -> (x, -(z + R), y + R + SPHERE_GAP).
    gmsh.model.mesh.affineTransform([1, 0, 0, 0,
                                     0, 0, -1, -R,
                                     0, 1, 0, R + SPHERE_GAP])
    _write("sphere_upper.msh")
    gmsh.finalize()


def sphere_quarter():
    _start("sphere_quarter")
    occ = gmsh.model.occ
    # angle3 = pi/2: the quarter of the ball swept from the x axis to the y axis.
    vol = occ.addSphere(0, 0, -R, R, angle1=-math.pi / 2, angle2=math.pi / 2, angle3=math.pi / 2)
    occ.synchronize()
    groups = {"curved": [], "xsym": [], "ysym": []}
    for _, s in gmsh.model.getBoundary([(3, vol)], oriented=False):
        c = occ.getCenterOfMass(2, s)
        groups["xsym" if abs(c[0]) < 1e-9 else "ysym" if abs(c[1]) < 1e-9 else "curved"].append(s)
    assert all(len(tags) == 1 for tags in groups.values()), groups
    _name_surfaces(groups, vol)
    # Graded in the whole volume by the distance from the top pole: 0.1 within 1 of it (the
    # contact radius is about 0.26), 1.0 from 4 on. A field restricted to the surface, with a
    # coarse volume under it, leaves the ball too stiff (sphere.msh, 1.3 inside, at 0.1 m/s:
    # Hertz peak force +12.7 %; quarter balls graded in the volume: +5.4 to +7.0 %).
    gmsh.model.mesh.field.setAsBackgroundMesh(_threshold("Sqrt(x^2 + y^2 + z^2)", 0.1, 1.0, 1.0, 4.0))
    for opt in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(opt, 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 1.0)
    gmsh.model.mesh.generate(3)
    _write("sphere_quarter.msh")
    gmsh.finalize()


def block(name, z0, size, face, face_size):
    _start(name)
    occ = gmsh.model.occ
    vol = occ.addBox(0, 0, z0, 10.0, 10.0, 5.0)
    occ.synchronize()
    groups = {}
    for _, s in gmsh.model.getBoundary([(3, vol)], oriented=False):
        c = occ.getCenterOfMass(2, s)
        for axis, lo, hi, names in ((0, 0.0, 10.0, ("xmin", "xmax")), (1, 0.0, 10.0, ("ymin", "ymax")),
                                    (2, z0, z0 + 5.0, ("bottom", "top"))):
            if abs(c[axis] - lo) < 1e-9:
                groups[names[0]] = [s]
            elif abs(c[axis] - hi) < 1e-9:
                groups[names[1]] = [s]
    assert len(groups) == 6, groups
    _name_surfaces(groups, vol)
    # ``face_size`` on the contact face, ``size`` elsewhere. (A "Constant" field under
    # "Restrict" is ignored by gmsh 4.15; a constant MathEval works.)
    f = gmsh.model.mesh.field
    c = f.add("MathEval")
    f.setString(c, "F", repr(float(face_size)))
    _restricted(c, groups[face])
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(3)
    _write(f"{name}.msh")
    gmsh.finalize()


if __name__ == "__main__":
    hemisphere()
    sphere()
    sphere_quarter()
    block("block_a", -5.0, 1.5, "top", 1.0)
    block("block_b", BLOCK_GAP, 2.0, "bottom", 1.5)
