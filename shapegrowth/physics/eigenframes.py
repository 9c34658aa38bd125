"""A field of symmetric 3 x 3 metrics as eigenvalue fields and Rodrigues angle fields.

``growth.start: target`` with the free 3D frame needs C_d = sum_i lambda_i v_i (x) v_i at
every growth node, with V = [v1 v2 v3] written as the Rodrigues angles (t1, t2, t3) of
(5.3)-(5.4).  The decomposition is not unique: the eigenvectors may be permuted (with their
eigenvalues) and their signs flipped, and where eigenvalues coincide any basis of the
eigenspace will do.  The fields are interpolated between nodes, so the choice must vary
continuously from node to node; a choice made node by node does not (a beam twisted about
its axis: sorting the eigenvalues turns the frame by 90 degrees across the mid-plane, where
lambda_1 and lambda_3 cross; the frame nearest the identity ties there).

So the nodes are visited along a minimum spanning tree of their nearest-neighbour graph
(built from the coordinates alone: serial and parallel runs choose the same frames), and
each node takes, of its 24 proper signed permutations of eigenvectors, the one nearest its
parent's frame; where the parent's frame already diagonalises the node's metric (equal
eigenvalues) it is kept.  The root takes the signed permutation nearest the identity (a
metric near diagonal keeps lambda_i along X_i).  A metric field whose frame cannot turn
continuously (a defect line) keeps its jump on the fewest tree edges.
"""

from __future__ import annotations

import itertools

import numpy as np

from .closed_forms import rodrigues_vectors

NEIGHBOURS = 8  # nearest-neighbour graph of the nodes: enough to connect P1/P2 node sets

# The 24 proper signed permutation matrices P (V -> V P keeps V a rotation when det P = 1).
_SIGNED_PERMUTATIONS = np.array([
    np.eye(3)[:, list(p)] * np.array(s)
    for p in itertools.permutations(range(3)) for s in itertools.product((1, -1), repeat=3)
    if np.linalg.det(np.eye(3)[:, list(p)] * np.array(s)) > 0])


def rodrigues_matrix(t1: np.ndarray, t2: np.ndarray, t3: np.ndarray) -> np.ndarray:
    """V (n, 3, 3) of (5.3) with k(t1, t2) of (5.4), its columns v1, v2, v3, at n points:
    the closed form (5.5) of closed_forms.py, evaluated on arrays."""
    rows = rodrigues_vectors(np.asarray(t1), np.asarray(t2), np.asarray(t3))  # (3, 3, n)
    return np.moveaxis(rows, -1, 0).transpose(0, 2, 1)


def rodrigues_angles(V: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t1, t2, t3) with rodrigues_matrix(t1, t2, t3) = V, for rotations V (n, 3, 3);
    t1 in [0, 2 pi), t2 in [0, pi], t3 in [0, pi] (the paper's default bounds)."""
    # V is the rotation by t3 about k (the K of (5.3) is minus the usual cross-product matrix):
    # V - V^T = 2 sin(t3) [k]_x and V + V^T - (tr V - 1) I = 2 (1 - cos t3) k k^T
    cos_t3 = (np.trace(V, axis1=1, axis2=2) - 1) / 2
    w = np.stack([V[:, 2, 1] - V[:, 1, 2], V[:, 0, 2] - V[:, 2, 0], V[:, 1, 0] - V[:, 0, 1]],
                 axis=1)  # 2 sin(t3) k
    norm = np.linalg.norm(w, axis=1)
    t3 = np.arctan2(norm / 2, cos_t3)  # accurate near 0 and near pi alike
    k = np.tile([0.0, 0.0, 1.0], (len(V), 1))  # no rotation: any axis
    small = (norm > 1e-12) & (cos_t3 >= 0)
    k[small] = w[small] / norm[small, None]
    large = cos_t3 < 0  # beyond a quarter turn: the symmetric part is well conditioned
    if large.any():
        S = V[large] + V[large].transpose(0, 2, 1) - 2 * cos_t3[large, None, None] * np.eye(3)
        col = np.argmax(np.einsum("nii->ni", S), axis=1)
        axis = S[np.arange(len(col)), :, col]
        axis /= np.linalg.norm(axis, axis=1)[:, None]
        axis[np.einsum("ni,ni->n", axis, w[large]) < 0] *= -1
        k[large] = axis
    t2 = np.arccos(np.clip(k[:, 2], -1.0, 1.0))
    t1 = np.mod(np.arctan2(k[:, 1], k[:, 0]), 2 * np.pi)
    return t1, t2, t3


def one_hemisphere(t1: np.ndarray, t2: np.ndarray, t3: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The same rotations with their axes k in one hemisphere and t3 signed: the rotation by
    t3 about k is the rotation by -t3 about -k, i.e. (t1 + pi, pi - t2, -t3).  With t3 in
    [0, pi], a frame field turning one way and then the other about one axis (the in-plane
    directions of a body grown into a disk, about X3) has its axis jump from k to -k where
    the turn changes sign; the interpolated angles between two such nodes are a rotation
    about an axis in between, which no node asked for (the cube of scene 6 started from its
    target's metric: 13.3 % against 6.6 % with the axes kept on one side, h 1).  The
    hemisphere is that of the axis most of the turning is about (the leading eigenvector of
    sum sin^2(t3 / 2) k k^T, its largest component made positive); t3 then lies in [-pi, pi]."""
    k = np.stack([np.sin(t2) * np.cos(t1), np.sin(t2) * np.sin(t1), np.cos(t2)], axis=1)
    weight = np.sin(t3 / 2) ** 2
    _, vecs = np.linalg.eigh(np.einsum("n,ni,nj->ij", weight, k, k))
    reference = vecs[:, -1]
    reference = reference * np.sign(reference[np.argmax(np.abs(reference))])
    flip = k @ reference < 0
    t1, t2, t3 = t1.copy(), t2.copy(), t3.copy()
    t1[flip] = np.mod(t1[flip] + np.pi, 2 * np.pi)
    t2[flip] = np.pi - t2[flip]
    t3[flip] = -t3[flip]
    return t1, t2, t3


def _spanning_order(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Breadth-first order of the nodes x (n, 3) along the minimum spanning tree of their
    nearest-neighbour graph, and each node's parent (-1 for roots), from node 0 of the
    lexicographic order (one root per connected piece)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree
    from scipy.spatial import cKDTree

    n = len(x)
    # Numbering-free, and partition-free: node coordinates computed cell by cell differ in
    # their last bits between 1 and N ranks (0 against 6e-17), which reorders tied nodes and
    # ties between edges, and the tree with them (the cube of scene 6 took other frames on 2
    # ranks); so coordinates and distances are compared rounded to 1e-9 of the body's size,
    # and edges of equal rounded length are ranked by their end nodes' sorted positions.
    scale = float(np.ptp(x, axis=0).max()) or 1.0
    order = np.lexsort(np.round(x / scale, 9).T[::-1])
    xs = x[order]
    k = min(NEIGHBOURS + 1, n)
    extra = min(k + 6, n)  # neighbours tied with the k-th are kept
    dist, nbr = cKDTree(xs).query(xs, k=extra)
    rounded = np.round(dist / scale, 9)
    keep = rounded[:, 1:] <= rounded[:, k - 1:k]
    rows = np.repeat(np.arange(n), extra - 1).reshape(n, extra - 1)[keep]
    cols = nbr[:, 1:][keep]
    lengths = rounded[:, 1:][keep]
    ranked = np.lexsort((np.maximum(rows, cols), np.minimum(rows, cols), lengths))
    weights = np.empty(len(ranked))
    weights[ranked] = np.arange(1, len(ranked) + 1)  # the MST depends on their order alone
    graph = coo_matrix((weights, (rows, cols)), shape=(n, n)).tocsr()
    tree = minimum_spanning_tree(graph)
    tree = tree + tree.T
    parent = np.full(n, -1)
    visited = np.zeros(n, dtype=bool)
    sequence = []
    for root in range(n):
        if visited[root]:
            continue
        seq, pred = breadth_first_order(tree, root, directed=False, return_predecessors=True)
        visited[seq] = True
        sequence.append(seq)
        parent[seq[1:]] = pred[seq[1:]]
    seq = np.concatenate(sequence)
    # back to the caller's numbering
    return order[seq], np.where(parent[seq] >= 0, order[np.maximum(parent[seq], 0)], -1)


def _nearest(scores: np.ndarray, candidates: np.ndarray, tied: float = 1e-8) -> int:
    """The candidate frame of the highest score (nearest the reference); a tie within
    ``tied`` (a node of a symmetric body, its parent's frame halfway between two of its own)
    goes to the candidate nearest the identity, then to the largest entries in order, so
    that round-off (the last bits of a node's metric on 1 or N ranks) does not decide it."""
    near = np.flatnonzero(scores >= scores.max() - tied)
    if len(near) == 1:
        return int(near[0])
    trace = np.einsum("pii->p", candidates[near])
    near = near[trace >= trace.max() - tied]
    keys = np.round(candidates[near].reshape(len(near), 9), 6)
    return int(near[np.lexsort(keys.T[::-1])[-1]])


def aligned_eigenframes(C: np.ndarray, x: np.ndarray,
                        degenerate: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (n, 3) and rotations V (n, 3, 3) with C = V diag(lambda) V^T at each
    node, V varying continuously from node to node where it can (module docstring).
    ``degenerate``: relative off-diagonal size below which a parent's frame diagonalises
    a node's metric and is kept."""
    w, vecs = np.linalg.eigh(C)
    w, vecs = w[:, ::-1], vecs[:, :, ::-1]  # largest first
    vecs[np.linalg.det(vecs) < 0, :, 2] *= -1
    lams = np.empty_like(w)
    frames = np.empty_like(vecs)
    seq, parent = _spanning_order(x)
    scale = np.abs(C).max(axis=(1, 2)) + 1e-300
    for node, up in zip(seq, parent):
        candidates = vecs[node] @ _SIGNED_PERMUTATIONS  # (24, 3, 3)
        reference = np.eye(3) if up < 0 else frames[up]
        if up >= 0:
            inherited = reference.T @ C[node] @ reference
            off = inherited - np.diag(np.diag(inherited))
            if np.abs(off).max() <= degenerate * scale[node]:
                frames[node], lams[node] = reference, np.diag(inherited)
                continue
        best = _nearest(np.einsum("ij,pij->p", reference, candidates), candidates)
        frames[node] = candidates[best]
        lams[node] = w[node] @ np.abs(_SIGNED_PERMUTATIONS[best])
    return lams, frames
