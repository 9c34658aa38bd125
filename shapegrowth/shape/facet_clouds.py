"""A face of the body as a weighted point cloud, its areas pushed forward exactly (Nanson).

The volume cloud (:mod:`.clouds`) samples the body at the quadrature points of its cells; a
face (a named part of the boundary, or all of it) is sampled at the quadrature points of its
facets: points Phi(X_q) = X_q + u(X_q), weights

    w_q |cof F(X_q) N(X_q)|      (da = J |F^-T N| dA = |cof F N| dA),

w_q the facet's reference area weights and N its outward unit normal, so that sums over the
cloud are integrals over the deformed face.  Everything is evaluated here with basix's
tabulations at the facets' points mapped into the reference cell (one map per local facet),
so it serves every cell kind (triangles, tetrahedra, quadrilaterals, hexahedra) and dolfinx
release alike.  The (R, Z) section of a body of revolution compares its edges as the
surfaces they sweep: weights w_q 2 pi r |cof F N| with the deformed radius r = R + u_R
(2 pi R at rest), whose derivative joins the points' (2 pi w_q |cof F N| on u_R).

A derivative of a function of the cloud with respect to its points (g_x) and weights (g_w)
becomes a derivative with respect to u through

    dJ/du [v] = sum_q g_x(q) . v(X_q) + g_w(q) w_q d|cof F N| [grad v](X_q),
    d|cof F N| [H] = det F ( (m . F^-T N) tr(F^-1 H) - m . F^-T H^T F^-T N ),  m = cof F N / |.|,

assembled here cell by cell (for H = e_k (x) grad phi_a: det F (r_k (p . N) - q_k (g . p)) with
g = grad phi_a, r = g^T F^-1, p = F^-1 m, q = F^-T N).  The elements' degrees are at most 2,
whose Lagrange DOFs need no permutation between neighbouring cells.
"""

from __future__ import annotations

from dataclasses import dataclass

import basix
import dolfinx.fem
import dolfinx.mesh
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat
from .hausdorff import PointCloud

_FACET = {"triangle": "interval", "quadrilateral": "interval", "tetrahedron": "triangle",
          "hexahedron": "quadrilateral"}


@dataclass(frozen=True)
class _Group:
    """The facets that are their cells' ``local``-th: the cells, the displacement element's
    values and reference gradients at the points (1 + tdim, nq, ndofs), the geometry
    element's (1 + tdim, nq, nnodes), the facet's reference outward normal and its points'
    reference area weights."""

    cells: np.ndarray
    phi: np.ndarray
    gphi: np.ndarray
    normal: np.ndarray
    weights: np.ndarray
    origin: np.ndarray  # the facet's first vertex in the reference cell
    tangents: np.ndarray  # (tdim, fdim): origin + tangents xi maps the reference facet


@dataclass(frozen=True)
class _Kinematics:
    """One group's displacement u, F^-1, det F and cof F N at its points (c, q, ...), and
    its rows of the cloud."""

    u: np.ndarray
    N: np.ndarray
    Finv: np.ndarray
    detF: np.ndarray
    cofN: np.ndarray
    rows: slice


def _element(cell: basix.CellType, degree: int):
    return basix.create_element(basix.ElementFamily.P, cell, degree,
                                basix.LagrangeVariant.gll_warped)


def _subdivision(facet: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A reference facet's lattice points xi (L, fdim) and its pieces (indices into them):
    a triangle in n^2 triangles, a quadrilateral in 2 n^2, an interval in n segments."""
    if facet == "interval":
        return (np.arange(n + 1, dtype=float)[:, None] / n,
                np.column_stack([np.arange(n), np.arange(1, n + 1)]))
    if facet == "quadrilateral":
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        xi = np.column_stack([i.ravel(), j.ravel()]) / n
        at = (n + 1) * i[:-1, :-1].ravel() + j[:-1, :-1].ravel()
        return xi, np.concatenate([np.column_stack([at, at + n + 1, at + n + 2]),
                                   np.column_stack([at, at + n + 2, at + 1])])
    index: dict[tuple[int, int], int] = {}
    points: list[tuple[float, float]] = []
    for a in range(n + 1):
        for b in range(n + 1 - a):
            index[a, b] = len(points)
            points.append((a / n, b / n))
    triangles: list[tuple[int, int, int]] = []
    for a in range(n):
        for b in range(n - a):
            triangles.append((index[a, b], index[a + 1, b], index[a, b + 1]))
            if a + b < n - 1:
                triangles.append((index[a + 1, b], index[a + 1, b + 1], index[a, b + 1]))
    return np.array(points), np.array(triangles)


def boundary_facets(mesh) -> np.ndarray:
    """The local facets on the body's boundary (each with one cell)."""
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, fdim + 1)
    return np.asarray(dolfinx.mesh.exterior_facet_indices(mesh.topology), dtype=np.int32)


class FacetCloud:
    """Quadrature points of degree ``degree`` on the boundary facets ``facets`` (local
    indices) of the displacement space ``space``'s mesh."""

    def __init__(self, space: dolfinx.fem.FunctionSpace, facets: np.ndarray, degree: int,
                 axisymmetric: bool = False):
        """``axisymmetric``: the mesh is the (R, Z) section of a body of revolution, its
        edges stand for surfaces of revolution (area 2 pi r times length)."""
        mesh = space.mesh
        self.space, self.mesh, self.degree = space, mesh, degree
        self.axisymmetric = axisymmetric
        tdim, self.gdim = mesh.topology.dim, mesh.geometry.dim
        if tdim != self.gdim:
            raise ValueError("a facet cloud needs a body of the space's own dimension")
        fdim = tdim - 1
        mesh.topology.create_connectivity(fdim, tdim)
        mesh.topology.create_connectivity(tdim, fdim)
        f_to_c = mesh.topology.connectivity(fdim, tdim)
        c_to_f = mesh.topology.connectivity(tdim, fdim)
        owned = mesh.topology.index_map(tdim).size_local
        cell_name = mesh.topology.cell_type.name
        cell = getattr(basix.CellType, cell_name)
        facet_cell = getattr(basix.CellType, _FACET[cell_name])
        ref_x = np.asarray(basix.geometry(cell), dtype=float)
        centre = ref_x.mean(axis=0)
        qpoints, qweights = basix.make_quadrature(facet_cell, degree)
        qpoints = np.asarray(qpoints, dtype=float).reshape(len(qweights), -1)
        self.nq = len(qweights)
        element = _element(cell, compat.space_degree(space))
        geometry = _element(cell, compat.geometry_degree(mesh))
        nodes = compat.geometry_nodes(mesh)
        # each facet's (one) cell, and which of the cell's facets it is
        cell_of = np.array([f_to_c.links(f)[0] for f in facets], dtype=np.int32)
        local = np.array([list(c_to_f.links(c)).index(f) for f, c in zip(facets, cell_of)],
                         dtype=np.int32)
        # per local facet: its cells, the tabulations at its points, its reference normal
        self.groups: list[_Group] = []
        for f, vertices in enumerate(basix.topology(cell)[fdim]):
            cells = cell_of[(local == f) & (cell_of < owned)]
            if len(cells) == 0:
                continue
            v = ref_x[vertices]
            tangents = (v[1:fdim + 1] - v[0]).T  # (tdim, fdim): v0 + T xi maps the facet
            points = v[0] + qpoints @ tangents.T
            if fdim == 2:
                normal = np.cross(tangents[:, 0], tangents[:, 1])
            else:
                normal = np.array([tangents[1, 0], -tangents[0, 0]])
            area = np.linalg.norm(normal)  # reference area per xi area
            normal = normal / area
            if normal @ (points.mean(axis=0) - centre) < 0:
                normal = -normal
            phi = element.tabulate(1, points)[:, :, :, 0]  # (1 + tdim, nq, ndofs)
            gphi = geometry.tabulate(1, points)[:, :, :, 0]  # (1 + tdim, nq, nnodes)
            self.groups.append(_Group(cells, phi, gphi, normal, np.asarray(qweights) * area,
                                      v[0], tangents))
        self._element, self._geometry, self._nodes = element, geometry, nodes
        self._prepare(nodes)

    def _prepare(self, nodes: np.ndarray) -> None:
        """Reference positions, unit normals and areas of every point, and the inverse
        Jacobians of the reference cells there."""
        x = self.mesh.geometry.x[:, :self.gdim]
        X, N, w, Jinv, dofs = [], [], [], [], []
        dofmap = self.space.dofmap
        for group in self.groups:
            xc = x[nodes[group.cells]]  # (nc, nnodes, gdim)
            J = np.einsum("cnx,tqn->cqxt", xc, group.gphi[1:])  # dX/dxi at the points
            Ji = np.linalg.inv(J)
            detJ = np.linalg.det(J)
            cof_n = detJ[..., None] * np.einsum("cqtx,t->cqx", Ji, group.normal)  # cof(J) n
            size = np.linalg.norm(cof_n, axis=-1)
            X.append(np.einsum("cnx,qn->cqx", xc, group.gphi[0]))
            N.append(cof_n / size[..., None])
            w.append(size * group.weights)
            Jinv.append(Ji)
            dofs.append(np.array([dofmap.cell_dofs(c) for c in group.cells], dtype=np.int64))
        self.X = np.concatenate([a.reshape(-1, self.gdim) for a in X]) if X else \
            np.zeros((0, self.gdim))
        self.N = np.concatenate([a.reshape(-1, self.gdim) for a in N]) if N else \
            np.zeros((0, self.gdim))
        self._w_plane = np.concatenate([a.reshape(-1) for a in w]) if w else np.zeros(0)
        self.w = self._w_plane * self._hoop(self.X[:, 0]) if self.axisymmetric else \
            self._w_plane  # (a body of revolution's: times 2 pi R)
        self._Jinv, self._dofs = Jinv, dofs

    @staticmethod
    def _hoop(radius: np.ndarray) -> np.ndarray:
        return 2 * np.pi * radius

    def __len__(self) -> int:
        return len(self.w)

    def lattice(self, u: dolfinx.fem.Function | None,
                n: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """This rank's face as flat pieces: each facet's reference facet subdivided n times
        (triangles, or segments in 2D), mapped into the body.  Returns the reference points
        (P, gdim), the deformed points X + u (the reference where ``u`` is None) and the
        simplices (S, fdim + 1), indices into the points."""
        fdim = self.mesh.topology.dim - 1
        xi, pieces = _subdivision(_FACET[self.mesh.topology.cell_type.name], n)
        x = self.mesh.geometry.x[:, :self.gdim]
        values = None if u is None else u.x.array.reshape(-1, self.gdim)
        X, moved, simplices, offset = [], [], [], 0
        for group, dofs in zip(self.groups, self._dofs):
            points = group.origin + xi @ group.tangents.T
            gphi = self._geometry.tabulate(0, points)[0, :, :, 0]  # (L, nnodes)
            Xg = np.einsum("cnx,ln->clx", x[self._nodes[group.cells]], gphi)
            Ug = np.zeros_like(Xg)
            if values is not None:
                phi = self._element.tabulate(0, points)[0, :, :, 0]  # (L, ndofs)
                Ug = np.einsum("cak,la->clk", values[dofs], phi)
            nc, L = Xg.shape[:2]
            X.append(Xg.reshape(-1, self.gdim))
            moved.append((Xg + Ug).reshape(-1, self.gdim))
            simplices.append((offset + L * np.arange(nc)[:, None, None] + pieces[None])
                             .reshape(-1, fdim + 1))
            offset += nc * L
        if not X:
            empty = np.zeros((0, self.gdim))
            return empty, empty, np.zeros((0, fdim + 1), dtype=np.int64)
        return np.concatenate(X), np.concatenate(moved), np.concatenate(simplices)

    def area(self) -> float:
        """The reference face's area (all ranks)."""
        return self.mesh.comm.allreduce(float(self.w.sum()), MPI.SUM)

    def reference(self) -> PointCloud:
        return PointCloud(self.X.copy(), self.w.copy())

    def _kinematics(self, u: dolfinx.fem.Function) -> list[_Kinematics]:
        """Per group: u, F^-1, det F and cof F N at its points, and its rows of the cloud."""
        bs = self.gdim
        values = u.x.array.reshape(-1, bs)
        out, start = [], 0
        for group, Ji, dofs in zip(self.groups, self._Jinv, self._dofs):
            uc = values[dofs]  # (nc, ndofs, bs)
            uq = np.einsum("cak,qa->cqk", uc, group.phi[0])
            grad_ref = np.einsum("cak,tqa->cqkt", uc, group.phi[1:])
            F = np.eye(bs) + np.einsum("cqkt,cqtx->cqkx", grad_ref, Ji)
            rows = slice(start, start + uq.shape[0] * uq.shape[1])
            N = self.N[rows].reshape(uq.shape)
            Fi, detF = np.linalg.inv(F), np.linalg.det(F)
            cofN = detF[..., None] * np.einsum("cqxk,cqx->cqk", Fi, N)  # det F F^-T N
            out.append(_Kinematics(uq, N, Fi, detF, cofN, rows))
            start = rows.stop
        return out

    def deformed(self, u: dolfinx.fem.Function) -> PointCloud:
        """The deformed face: points X + u, weights w |cof F N|."""
        points, weights = [], []
        for k in self._kinematics(u):
            moved = self.X[k.rows] + k.u.reshape(-1, self.gdim)
            points.append(moved)
            weight = self._w_plane[k.rows] * np.linalg.norm(k.cofN, axis=-1).ravel()
            weights.append(weight * self._hoop(moved[:, 0]) if self.axisymmetric else weight)
        if not points:
            return PointCloud(np.zeros((0, self.gdim)), np.zeros(0))
        return PointCloud(np.concatenate(points), np.concatenate(weights))

    def pullback(self, u: dolfinx.fem.Function, grad_points: np.ndarray,
                 grad_weights: np.ndarray) -> PETSc.Vec:
        """dJ/du as a vector on u's space, from J's derivatives with respect to the deformed
        cloud's points and weights (this rank's points; summed over the ranks)."""
        bs = self.gdim
        local = np.zeros(u.x.array.size)
        for k, group, Ji, dofs in zip(self._kinematics(u), self.groups, self._Jinv,
                                      self._dofs):
            phi = group.phi
            nc, nq = k.u.shape[:2]
            gx = grad_points[k.rows].reshape(nc, nq, bs)
            gw = (grad_weights[k.rows] * self._w_plane[k.rows]).reshape(nc, nq)
            if self.axisymmetric:  # w 2 pi r |cof F N|: r = R + u_R moves too
                area = np.linalg.norm(k.cofN, axis=-1)  # (c, q)
                radius = self.X[k.rows, 0].reshape(nc, nq) + k.u[..., 0]
                gx = gx.copy()
                gx[..., 0] += gw * area * 2 * np.pi
                gw = gw * self._hoop(radius)
            Fi, N = k.Finv, k.N
            m = k.cofN / np.linalg.norm(k.cofN, axis=-1)[..., None]
            p = np.einsum("cqkx,cqx->cqk", Fi, m)  # F^-1 m
            q = np.einsum("cqxk,cqx->cqk", Fi, N)  # F^-T N
            g = np.einsum("tqa,cqtx->cqax", phi[1:], Ji)  # physical gradients of the basis
            r = np.einsum("cqax,cqxk->cqak", g, Fi)  # g^T F^-1
            pN = np.einsum("cqk,cqk->cq", p, N)
            gp = np.einsum("cqax,cqx->cqa", g, p)
            da = k.detF[..., None, None] * (r * pN[..., None, None]
                                            - q[:, :, None, :] * gp[..., None])  # (c,q,a,k)
            contribution = (np.einsum("cqk,qa->cak", gx, phi[0])
                            + np.einsum("cq,cqak->cak", gw, da))
            np.add.at(local, (dofs[:, :, None] * bs + np.arange(bs)).ravel(),
                      contribution.ravel())
        out = dolfinx.fem.Function(u.function_space)
        out.x.array[:] = local
        vec = compat.petsc_vec(out)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return vec.copy()  # owned by the caller, not by ``out``

