"""Tetrahedral meshes of boxes and their volumes: what soft-body simulations (thesis 3.3.4) and deformability
probing (thesis app. A) share.

Meshes are conforming: each hexahedral cell is split into five tetrahedra, the split mirrored in every other cell
(checkerboard parity) so that neighbouring cells share their face diagonals.  ``write_vtk`` writes the ASCII VTK
unstructured grid that pybullet's ``loadSoftBody`` reads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pliant.errors import ConfigError

# five tetrahedra per hexahedral cell (corners numbered as in the VTK hexahedron); the mirrored split
# (x -> 1 - x: corners 0<->1, 3<->2, 4<->5, 7<->6) for cells of odd parity keeps the mesh conforming
_CELL_TETS = ((0, 1, 3, 4), (1, 2, 3, 6), (1, 4, 5, 6), (3, 4, 6, 7), (1, 3, 4, 6))
_MIRROR = (1, 0, 3, 2, 5, 4, 7, 6)
_CELL_TETS_MIRRORED = tuple(tuple(_MIRROR[c] for c in t) for t in _CELL_TETS)


def _cells3(cells) -> tuple[int, int, int]:
    c = np.broadcast_to(np.asarray(cells), (3,))
    if not np.issubdtype(c.dtype, np.integer) or np.any(c < 1):
        raise ConfigError("cells per axis must be integers >= 1", field="cells", value=np.asarray(cells).tolist())
    return int(c[0]), int(c[1]), int(c[2])


def box_ticks(size, cells, snap=None) -> list[np.ndarray]:
    """Node coordinates per axis (3 arrays, m) of a box of ``size`` centred at the origin.

    ``cells`` (an int or one per axis) uniform intervals per axis; ``snap`` an optional ``(lower (3,),
    upper (3,))`` box (e.g. a rigid core) whose faces are made node planes by moving, on each axis, the
    nearest interior node not yet moved onto each face, so the cell counts are unchanged.  Faces on or
    outside the box are ignored.  Requires at least two cells on an axis to snap both of its faces.
    """
    size = np.broadcast_to(np.asarray(size, dtype=np.float64), (3,))
    if np.any(~np.isfinite(size)) or np.any(size <= 0):
        raise ConfigError("box size must be positive and finite (m)", field="size", value=size.tolist())
    counts = _cells3(cells)
    ticks = [np.linspace(-size[i] / 2, size[i] / 2, counts[i] + 1) for i in range(3)]
    if snap is None:
        return ticks
    lower, upper = (np.asarray(v, dtype=np.float64) for v in snap)
    for i in range(3):
        t = ticks[i]
        used = {0, len(t) - 1}
        for face in (lower[i], upper[i]):
            if not (t[0] < face < t[-1]):
                continue
            free = [k for k in range(1, len(t) - 1) if k not in used]
            if not free:
                raise ConfigError("too few cells to put the core's faces on node planes", field="cells",
                                  value=list(counts))
            k = min(free, key=lambda j: abs(t[j] - face))
            t[k] = face
            used.add(k)
        t.sort()
        if np.any(np.diff(t) <= 1e-9 * size[i]):
            raise ConfigError("snapping made two node planes coincide", field="cells", value=list(counts))
    return ticks


def box_tetrahedra(size, cells, snap=None) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``(k, 3)`` (m) and tetrahedra ``(t, 4)`` filling a box of ``size`` centred at the origin.

    ``cells`` hexahedra per axis (an int or one per axis), five tetrahedra each (``5 nx ny nz`` in
    all; ``(5, 4, 4)`` gives the thesis's 400); ``snap`` as in :func:`box_ticks`.  Thesis 3.3.4.
    """
    ticks = box_ticks(size, cells, snap)
    n = [len(t) for t in ticks]
    nodes = np.stack(np.meshgrid(*ticks, indexing="ij"), axis=-1).reshape(-1, 3)

    def index(i, j, k):
        return (i * n[1] + j) * n[2] + k

    tets = []
    for i in range(n[0] - 1):
        for j in range(n[1] - 1):
            for k in range(n[2] - 1):
                corners = (index(i, j, k), index(i + 1, j, k), index(i + 1, j + 1, k), index(i, j + 1, k),
                           index(i, j, k + 1), index(i + 1, j, k + 1), index(i + 1, j + 1, k + 1),
                           index(i, j + 1, k + 1))
                split = _CELL_TETS if (i + j + k) % 2 == 0 else _CELL_TETS_MIRRORED
                tets.extend([corners[a] for a in t] for t in split)
    tets = np.array(tets, dtype=np.int64)
    # one orientation for all (positive signed volume): Bullet's soft body goes unstable with mixed ones
    a, b, c, d = (nodes[tets[:, i]] for i in range(4))
    negative = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    return nodes, tets


def tetrahedron_volumes(nodes: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Unsigned volumes ``(t,)`` (m^3) of tetrahedra ``(t, 4)`` over ``nodes`` ``(k, 3)``."""
    a, b, c, d = (nodes[tets[:, i]] for i in range(4))
    return np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))) / 6.0


def write_vtk(nodes: np.ndarray, tets: np.ndarray, path: Path) -> Path:
    """Write an ASCII VTK unstructured grid of tetrahedra (the format pybullet's ``loadSoftBody`` reads)."""
    lines = ["# vtk DataFile Version 2.0", "pliant tetrahedral mesh", "ASCII", "DATASET UNSTRUCTURED_GRID",
             f"POINTS {len(nodes)} double", *(f"{x:.17g} {y:.17g} {z:.17g}" for x, y, z in nodes.tolist()),
             f"CELLS {len(tets)} {5 * len(tets)}", *("4 " + " ".join(map(str, t)) for t in tets),
             f"CELL_TYPES {len(tets)}", *("10" for _ in tets)]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)
