"""Field snapshots as VTU files (ParaView's unstructured grid), written without meshio.

A run writes one file per body every ``[output] every`` steps, each with the body's reference
points and tetrahedra and its fields at the nodes. meshio compresses and encodes the points
and the cells again for every file; they never change, so :class:`FieldFileWriter` encodes
them once per body and each file adds only its point data (on the medium M5 fold the cells are
two thirds of a file's bytes). The files follow VTK's XML format as meshio writes it: binary
inline data, base64, compressed in 32 KiB blocks with a UInt32 block header (``zlib``,
``lzma``) or not compressed (``none``), the cell types one byte each as VTK writes them
(meshio writes eight); meshio and ParaView read them. What a file costs against meshio:
docs/performance.md, "Measurements behind the code's choices".

>>> import numpy as np, meshio, os, tempfile
>>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
>>> w = FieldFileWriter(points, np.array([[0, 1, 2, 3]]))
>>> path = os.path.join(tempfile.mkdtemp(), "a.vtu")
>>> w.write(path, {"displacement": np.ones((4, 3))}, compression="zlib")
>>> m = meshio.read(path)
>>> m.cells[0].type, m.point_data["displacement"].sum()
('tetra', np.float64(12.0))
"""

from __future__ import annotations

import base64
import lzma
import os
import zlib
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import MeshError

#: ``[output] compression`` -> (VTK's compressor name, the compress function), None: none.
COMPRESSORS = {
    "zlib": ("vtkZLibDataCompressor", zlib.compress),
    "lzma": ("vtkLZMADataCompressor", lzma.compress),
    "none": None,
}

_VTK_TYPES = {
    np.dtype(np.float64): "Float64", np.dtype(np.float32): "Float32",
    np.dtype(np.int64): "Int64", np.dtype(np.int32): "Int32", np.dtype(np.uint8): "UInt8",
}

_BLOCK = 32768  # bytes per compressed block (as meshio and VTK write them)
_VTK_TETRA = 10
_VTK_QUADRATIC_TETRA = 24


def encode(data: np.ndarray, compression: str) -> str:
    """The base64 text of a DataArray in VTK's binary inline format."""
    raw = np.ascontiguousarray(data).tobytes()
    spec = COMPRESSORS[compression]
    if spec is None:
        if len(raw) >= 2**32:
            raise MeshError(f"an uncompressed VTU array holds less than 4 GiB, this one {len(raw)} bytes: "
                            "use compression = 'zlib'")
        return base64.b64encode(np.uint32(len(raw)).tobytes() + raw).decode()
    compress = spec[1]
    blocks = [compress(raw[i:i + _BLOCK]) for i in range(0, len(raw), _BLOCK)] or [compress(b"")]
    last = len(raw) - (len(blocks) - 1) * _BLOCK
    header = np.array([len(blocks), _BLOCK, last] + [len(b) for b in blocks], dtype=np.uint32)
    return base64.b64encode(header.tobytes()).decode() + base64.b64encode(b"".join(blocks)).decode()


def _data_array(name: str, data: np.ndarray, compression: str) -> str:
    data = np.asarray(data)
    vtk = _VTK_TYPES.get(data.dtype)
    if vtk is None:
        raise MeshError(f"field {name!r}: a VTU file holds floats or integers, not {data.dtype}")
    components = f' NumberOfComponents="{data.shape[1]}"' if data.ndim == 2 else ""
    return (f'<DataArray type="{vtk}" Name={quoteattr(name)}{components} format="binary">\n'
            f"{encode(data, compression)}\n</DataArray>\n")


class FieldFileWriter:
    """Writes VTU files of one body's mesh (``points`` (n, 3), ``tets`` (m, 4), or (m, 10)
    ten-node tetrahedra written as VTK's quadratic tetrahedra, which ParaView draws curved) with
    point data; the points and cells are encoded once per compression and kept."""

    def __init__(self, points, tets):
        self.points = np.ascontiguousarray(points, dtype=np.float64)
        self.tets = np.ascontiguousarray(tets, dtype=np.int64)
        if self.points.ndim != 2 or self.points.shape[1] != 3 or self.tets.ndim != 2 or self.tets.shape[1] not in (4, 10):
            raise MeshError(f"a VTU field file needs points (n, 3) and tetrahedra (m, 4) or (m, 10), got "
                            f"{self.points.shape} and {self.tets.shape}")
        self._head: dict = {}

    def _geometry(self, compression: str) -> str:
        head = self._head.get(compression)
        if head is None:
            n, m = len(self.points), len(self.tets)
            spec = COMPRESSORS[compression]
            compressor = f' compressor="{spec[0]}"' if spec is not None else ""
            head = self._head[compression] = (
                '<?xml version="1.0"?>\n'
                f'<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian"{compressor}>\n'
                "<!--This file was created by vfrs-->\n"
                f'<UnstructuredGrid>\n<Piece NumberOfPoints="{n}" NumberOfCells="{m}">\n'
                "<Points>\n" + _data_array("Points", self.points, compression) + "</Points>\n"
                "<Cells>\n"
                + _data_array("connectivity", self.tets.ravel(), compression)
                + _data_array("offsets", self.tets.shape[1] * np.arange(1, m + 1, dtype=np.int64), compression)
                + _data_array("types", np.full(m, _VTK_TETRA if self.tets.shape[1] == 4 else _VTK_QUADRATIC_TETRA,
                                               dtype=np.uint8), compression)
                + "</Cells>\n")
        return head

    def write(self, path, point_data: dict, compression: str = "zlib") -> None:
        """``path``: the .vtu file; ``point_data``: name -> (n,) or (n, k) array per node."""
        if compression not in COMPRESSORS:
            raise MeshError(f"compression {compression!r}: choose one of {sorted(COMPRESSORS)}")
        n = len(self.points)
        parts = [self._geometry(compression), "<PointData>\n"]
        for name, values in point_data.items():
            values = np.asarray(values)
            if values.shape[:1] != (n,) or values.ndim > 2:
                raise MeshError(f"field {name!r}: {values.shape} values for {n} points")
            parts.append(_data_array(name, values, compression))
        parts.append("</PointData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n")
        with open(os.fspath(path), "w") as fh:
            fh.write("".join(parts))
