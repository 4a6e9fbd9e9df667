//! Contact geometry: projection, detection (interface gap mesh, BVH), constraint matrix.
