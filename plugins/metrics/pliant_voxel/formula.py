"""The per-voxel cost of deformation, thesis eq. 3.1.

``C(A, B) = D_A / (D_A + D_B) * S_A + D_B / (D_A + D_B) * S_B`` for a robot voxel ``A`` overlapping
an environment voxel ``B``: the softer voxel (higher deformability ``D``) contributes more of its
sensitivity ``S``.  Both rigid (``D_A = D_B = 0``) is undefined: NaN, the implicit collision of the
thesis; a NaN sensitivity marks a forbidden object and propagates (IEEE NaN "poisons" the sum).
"""

from __future__ import annotations

import numpy as np


def deformation_cost(d_robot, s_robot, d_env, s_env) -> np.ndarray:
    """Eq. 3.1, elementwise over broadcast arrays; NaN where both deformabilities are zero."""
    d_robot, s_robot, d_env, s_env = (np.asarray(x, dtype=np.float64) for x in (d_robot, s_robot, d_env, s_env))
    total = d_robot + d_env
    with np.errstate(invalid="ignore", divide="ignore"):
        # the weights first, as eq. 3.1 writes them: they stay in [0, 1] even for subnormal deformabilities
        weight = d_robot / total
        cost = weight * s_robot + (1.0 - weight) * s_env
    return np.where(total > 0, cost, np.nan)


def cost_tables(robot_materials: np.ndarray, deformability: np.ndarray, sensitivity: np.ndarray,
                occupied: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-(robot material class, environment voxel) cost tables.

    Returns ``classes`` ``(m,)`` (the class of each robot point) and ``table`` ``(c, N + 1)``: the cost
    of a point of class ``c`` in flat voxel ``v``; free voxels cost 0; the extra last column
    (index ``N``) is "outside the grid" and is NaN.
    """
    unique, classes = np.unique(np.asarray(robot_materials, dtype=np.float64), axis=0, return_inverse=True)
    n = occupied.size
    table = np.zeros((len(unique), n + 1))
    occ = occupied.reshape(-1)
    d_env = deformability.reshape(-1)[occ]
    s_env = sensitivity.reshape(-1)[occ]
    for c, (d, s) in enumerate(unique):
        table[c, :n][occ] = deformation_cost(d, s, d_env, s_env)
    table[:, n] = np.nan
    return classes.reshape(-1).astype(np.int64), table


def compress_table(table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A cost table ``(c, N + 1)`` as the material id of every voxel and a small lookup table.

    Returns ``materials`` ``(N + 1,)`` (the smallest unsigned integer type that holds the ids) and ``lut``
    ``(c, k)`` with ``lut[:, materials[v]] == table[:, v]`` for every voxel ``v`` (NaN columns included:
    they are told apart by their bits, so a forbidden object and the outside may share an id).  Scenes have a
    few materials, so ``materials`` takes one byte per voxel where ``table`` takes eight per class.
    """
    columns = np.ascontiguousarray(np.asarray(table, dtype=np.float64).T)
    keys = columns.view(np.dtype((np.void, columns.dtype.itemsize * columns.shape[1]))).reshape(-1)
    _, first, ids = np.unique(keys, return_index=True, return_inverse=True)
    return ids.reshape(-1).astype(code_dtype(len(first))), np.ascontiguousarray(columns[first].T)


def code_dtype(count: int) -> type:
    """The smallest unsigned integer type that holds ``count`` distinct codes (0 .. count - 1)."""
    return np.uint8 if count <= 2**8 else np.uint16 if count <= 2**16 else np.uint32
