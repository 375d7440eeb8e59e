r"""Axisymmetric total-Lagrangian large-strain solid on scikit-fem bases.

Coordinates are ``(r, z)`` (mm), displacements ``(u_r, u_z)``. The deformation
gradient in the cylindrical basis ``(r, z, theta)`` has five non-zero components

.. math::

    F = \begin{pmatrix} 1 + u_{r,r} & u_{r,z} & 0 \\ u_{z,r} & 1 + u_{z,z} & 0 \\
        0 & 0 & 1 + u_r / r \end{pmatrix},

and the weak form of equilibrium in the reference configuration is

.. math::

    \int_{\Omega_0} P(F) : \delta F \; 2\pi r \, dr\, dz + \delta\Pi_c = 0 .

:class:`AxisymmetricSolid` evaluates this form and its consistent tangent
:math:`\int \delta F : \mathbb{A} : \Delta F \, dV` with the shape-function values
and gradients of a scikit-fem :class:`~skfem.CellBasis` (P2 triangles by default),
and scatters element matrices into a sparsity pattern computed once. The same
form written with scikit-fem's ``BilinearForm`` lives in :mod:`.weakform` and
the two are tested to agree.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from skfem import Basis, ElementTriP2, ElementVector

from .layers import LayeredSample
from .materials import Material, NeoHooke, NeoHookeStiffening
from .materials.axisymmetric_hyperelastic import AxisymmetricStiffening
from .materials.base import cauchy_stress

#: (row, column) of the five non-zero components of F, order used throughout.
F_COMPONENTS = ((0, 0), (0, 1), (1, 0), (1, 1), (2, 2))
#: Quadrature order of the cells: 2 is three points per P2 triangle (exact for the
#: stiffness of plane linear elasticity on straight triangles). Against six points
#: (order 4), measured on the default mesh: the independent reference curves (neo-Hooke,
#: layer over a soft half-space, layer on a rigid base, stiffening, viscoelastic) agree
#: as closely (largest error for h >= 0.05 mm 0.069 / 0.341 / 0.151 / 0.068 / 0.060 %
#: against 0.070 / 0.350 / 0.165 / 0.066 / 0.058 %), F(0.6 mm) moves by 2e-5 on the
#: default mesh and by 1e-6 on the uniformly refined coarse mesh, and every curve costs
#: 20-30 % less (issue 15). Order 3 has a negative weight; it is not used.
QUADRATURE_ORDER = 2


class SparsityPattern:
    """Scatter of dense element blocks into a fixed CSR matrix over the free dofs.

    Parameters
    ----------
    element_dofs : ndarray of int, shape (n_local, n_blocks)
        Global dof of each local dof of each block.
    free : ndarray of bool, shape (n_dofs,)
        Which dofs are unknowns (Dirichlet dofs are removed).
    """

    def __init__(self, element_dofs: np.ndarray, free: np.ndarray):
        n_dofs = free.size
        self.free_index = np.full(n_dofs, -1, dtype=np.int64)
        self.free_index[free] = np.arange(np.count_nonzero(free))
        self.n = int(np.count_nonzero(free))
        rows, cols, keep = self._coo(element_dofs)
        rows, cols = rows[keep], cols[keep]
        # the CSR structure by scipy's counting sort (duplicates summed, indices sorted),
        # then each block entry's place in it: half the time of np.unique on the keys
        A = sparse.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(self.n, self.n)).tocsr()
        A.sum_duplicates()
        self.indptr = A.indptr.astype(np.int64)
        self.indices = A.indices.astype(np.int64)
        self._unique_keys = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(self.indptr)) * self.n + self.indices
        self._blocks = {id(element_dofs): (keep, np.searchsorted(self._unique_keys, rows * self.n + cols))}

    def _coo(self, element_dofs):
        fi = self.free_index[element_dofs]  # (n_local, n_blocks)
        nl = element_dofs.shape[0]
        rows = np.broadcast_to(fi[:, None, :], (nl, nl, fi.shape[1])).transpose(2, 0, 1).ravel()
        cols = np.broadcast_to(fi[None, :, :], (nl, nl, fi.shape[1])).transpose(2, 0, 1).ravel()
        return rows, cols, (rows >= 0) & (cols >= 0)

    def register(self, element_dofs: np.ndarray) -> None:
        """Register another family of blocks whose entries lie inside the pattern."""
        rows, cols, keep = self._coo(element_dofs)
        keys = rows[keep] * self.n + cols[keep]
        pos = np.searchsorted(self._unique_keys, keys)
        if np.any(self._unique_keys[np.minimum(pos, self._unique_keys.size - 1)] != keys):
            raise ValueError("block entries outside the sparsity pattern")
        self._blocks[id(element_dofs)] = (keep, pos)

    def assemble(self, blocks: list[tuple[np.ndarray, np.ndarray]]) -> sparse.csr_matrix:
        """Sum dense blocks ``(element_dofs, K_e)`` with ``K_e`` of shape (n_blocks, nl, nl)."""
        data = np.zeros(self._unique_keys.size)
        for element_dofs, Ke in blocks:
            keep, pos = self._blocks[id(element_dofs)]
            data += np.bincount(pos, weights=Ke.ravel()[keep], minlength=data.size)
        return sparse.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def _selector(ix: np.ndarray, shape):
    """Element indices or a (nel, nq) boolean mask; a full contiguous range becomes a slice
    (views instead of copies in the hot loop)."""
    if ix.dtype == bool:
        if ix.shape != shape:
            raise ValueError(f"a quadrature-point mask must have shape {shape}, got {ix.shape}")
        return slice(None) if ix.all() else ix
    if ix.size and np.array_equal(ix, np.arange(ix[0], ix[0] + ix.size)):
        return slice(int(ix[0]), int(ix[0] + ix.size))
    return ix


class AxisymmetricSolid:
    """Internal forces and tangent of an axisymmetric hyperelastic body.

    Parameters
    ----------
    mesh : skfem.MeshTri
        Reference configuration, lengths in mm.
    material : Material or LayeredSample
        The constitutive law, or a layered sample (materials by depth).
    element : skfem element, optional
        Scalar element (default :class:`~skfem.ElementTriP2`), used for both components.
    intorder : int
        Quadrature order (default :data:`QUADRATURE_ORDER`: three points per triangle).
    regions : sequence of (selector, Material), optional
        Different materials in different parts of the body (layers). A selector is
        an array of element indices, or a boolean mask of shape (nel, nq) choosing
        quadrature points (a material interface that cuts through elements).
        Overrides ``material``.

    Notes
    -----
    History-dependent laws (``path_independent = False``) keep a state per
    quadrature point here. :meth:`begin_step` freezes the law over a time step
    of ``dt`` seconds from the committed state, :meth:`commit` stores the state
    of a converged step; a failed (cut) step leaves the committed state intact.
    """

    def __init__(self, mesh, material: Material | None, element=None, intorder: int = QUADRATURE_ORDER,
                 regions=None):
        self.basis = Basis(mesh, ElementVector(element or ElementTriP2()), intorder=intorder)
        b = self.basis
        self.n_dofs = b.N
        self.element_dofs = b.element_dofs  # (12, nel)
        nloc = self.element_dofs.shape[0]
        x = np.asarray(b.global_coordinates())  # (2, nel, nq)
        r = x[0]
        self.r = r
        self.dV = 2.0 * np.pi * r * b.dx  # (nel, nq) reference volume of each quadrature point
        nel, nq = r.shape
        # G[c, k, e, q] = dF_c / du_k with the component order of F_COMPONENTS
        G = np.zeros((5, nloc, nel, nq))
        for k in range(nloc):
            phi = b.basis[k][0]
            value = np.asarray(phi)  # (2, nel, nq): the vector shape function
            comp = 0 if np.any(value[0]) else 1
            grad = phi.grad[comp]  # (2, nel, nq): d/dr, d/dz of component `comp`
            if comp == 0:
                G[0, k] = grad[0]
                G[1, k] = grad[1]
                G[4, k] = value[0] / r
            else:
                G[2, k] = grad[0]
                G[3, k] = grad[1]
        # local dofs reordered: all u_r dofs first, then all u_z dofs (contiguous blocks of G)
        order = np.r_[np.flatnonzero(np.any(G[[0, 1, 4]] != 0, axis=(0, 2, 3))),
                      np.flatnonzero(np.any(G[[2, 3]] != 0, axis=(0, 2, 3)))]
        if order.size != nloc or np.any(G[[2, 3]][:, order[:nloc // 2]]) or np.any(G[[0, 1, 4]][:, order[nloc // 2:]]):
            raise ValueError("each local dof must belong to one displacement component")
        G = G[:, order]
        self.element_dofs = self.element_dofs[order]
        self._nr = nloc // 2
        self.G = G
        # element-major copies for batched matrix products: (nel, 5*nq, nloc) and its transpose
        self._Ge = np.ascontiguousarray(G.transpose(2, 0, 3, 1).reshape(nel, 5 * nq, nloc))
        self._GeT = np.ascontiguousarray(self._Ge.transpose(0, 2, 1))
        # the non-zero blocks of G: components (0, 1, 4) act on u_r dofs, (2, 3) on u_z dofs
        nr = self._nr
        self._G_r = np.ascontiguousarray(G[[0, 1, 4], :nr].transpose(0, 2, 3, 1))  # (3, nel, nq, nr)
        self._G_z = np.ascontiguousarray(G[[2, 3], nr:].transpose(0, 2, 3, 1))  # (2, nel, nq, nz)
        self._cache = None  # (u, H) of the last evaluation, reused by tangent()
        if regions is None:
            if material is None:
                raise ValueError("give a material or regions")
            regions = material.regions(x[1]) if isinstance(material, LayeredSample) else [(np.arange(nel), material)]
        self.regions = [(_selector(np.asarray(ix), (nel, nq)), mat) for ix, mat in regions]
        self.small_strain = all(m.small_strain for _, m in self.regions)
        if len({m.small_strain for _, m in self.regions}) > 1:
            raise ValueError("all materials of a body must be either small-strain or finite-strain")
        self.path_independent = all(m.path_independent for _, m in self.regions)
        self.states = [None if m.path_independent else m.initial_state(self._selected_shape(sel))
                       for sel, m in self.regions]
        self._active = [m for _, m in self.regions]
        self._merged = self._merge_neo_hooke_regions()

    def _merge_neo_hooke_regions(self):
        """One :class:`~.materials.axisymmetric_hyperelastic.AxisymmetricStiffening` for a body made
        only of neo-Hookean regions, with or without strain stiffening (a half-space, bonded
        layers), covering every quadrature point once, else None."""
        if not all(type(m) in (NeoHooke, NeoHookeStiffening) for _, m in self.regions):
            return None
        mu, lam, c20 = np.zeros(self.r.shape), np.zeros(self.r.shape), np.zeros(self.r.shape)
        count = np.zeros(self.r.shape, dtype=int)
        for ix, m in self.regions:
            mu[ix], lam[ix] = m.lame
            c20[ix] = getattr(m, "C20_kPa", 0.0)
            count[ix] += 1
        return AxisymmetricStiffening(mu, lam, c20) if np.all(count == 1) else None

    def _selected_shape(self, sel):
        return np.zeros(self.r.shape)[sel].shape

    def begin_step(self, dt: float) -> None:
        """Freeze history-dependent laws over a time step of ``dt`` seconds."""
        self._active = [m if state is None else m.step(state, dt)
                        for (_, m), state in zip(self.regions, self.states)]

    def commit(self, u: np.ndarray, dt: float) -> None:
        """Store the history of the converged state ``u`` reached over ``dt`` seconds."""
        if self.path_independent:
            return
        H = self.displacement_gradient(u)
        self.states = [None if state is None else m.commit(H[:, :, sel], state, dt)
                       for (sel, m), state in zip(self.regions, self.states)]

    @property
    def n_elements(self) -> int:
        return self.r.shape[0]

    def displacement_gradient(self, u: np.ndarray) -> np.ndarray:
        """H = F - I (3, 3, nel, nq) from the nodal displacement vector ``u`` (mm)."""
        nel, nq = self.r.shape
        ue = u[self.element_dofs].T  # (nel, nloc)
        comps = np.matmul(self._Ge, ue[:, :, None]).reshape(nel, 5, nq).transpose(1, 0, 2)  # (5, nel, nq)
        H = np.zeros((3, 3) + comps.shape[1:])
        for c, (i, j) in enumerate(F_COMPONENTS):
            H[i, j] = comps[c]
        return H

    def _material_loop(self, F, want_tangent):
        """Evaluate each region's material on its elements."""
        if self._merged is not None:
            if want_tangent:
                return self._merged.tangent_components(F, F_COMPONENTS)
            return self._merged.stress_components(F, F_COMPONENTS), None
        P5 = np.empty((5,) + F.shape[2:])
        A55 = np.empty((5, 5) + F.shape[2:]) if want_tangent else None
        for (ix, _), mat in zip(self.regions, self._active):
            Fi = F[:, :, ix]
            if want_tangent:
                P5[:, ix], A55[:, :, ix] = mat.tangent_components(Fi, F_COMPONENTS)
            else:
                P = mat.stress(Fi)
                for a, (i, j) in enumerate(F_COMPONENTS):
                    P5[a][ix] = P[i, j]
        return P5, A55

    def energy(self, u: np.ndarray) -> float:
        """Stored energy (mN mm) of the displacement field ``u``."""
        if not self.path_independent:
            raise ValueError("a history-dependent body has no stored-energy function")
        F = self.displacement_gradient(u)
        W = np.empty(F.shape[2:])
        for ix, mat in self.regions:
            W[ix] = mat.energy(F[:, :, ix])
        return float(np.sum(W * self.dV))

    def forces(self, u: np.ndarray, tangent: bool = True):
        """Internal force vector (mN) and, if asked, element tangents.

        Returns
        -------
        f : ndarray, shape (n_dofs,)
        Ke : ndarray, shape (nel, nloc, nloc), or None
        """
        H = self.displacement_gradient(u)
        self._cache = (u.copy(), H)
        P5, A55 = self._material_loop(H, tangent)
        nel, nq = self.r.shape
        # f_e = G_e^T (P dV): one (nloc x 5nq) @ (5nq) product per element
        fe = np.matmul(self._GeT, (P5 * self.dV).transpose(1, 0, 2).reshape(nel, 5 * nq, 1))[:, :, 0]
        dofs = self.element_dofs.T.ravel()
        f = np.bincount(dofs, weights=fe.ravel(), minlength=self.n_dofs)
        # gross internal force: the scale of the round-off in f (large locked-in stresses
        # with a small net force, e.g. a viscoelastic body losing contact on unloading)
        self.gross_force = float(np.linalg.norm(np.bincount(dofs, weights=np.abs(fe).ravel(),
                                                            minlength=self.n_dofs)))
        if not tangent:
            return f, None
        return f, self._element_tangents(A55)

    def assemble_stress(self, P5: np.ndarray) -> np.ndarray:
        """Nodal force vector ``int P : dF/du dV`` (mN) of a stress field given at the quadrature points.

        Parameters
        ----------
        P5 : ndarray, shape (5, nel, nq)
            Components :data:`F_COMPONENTS` of a first Piola stress (or of its
            derivative with respect to a parameter), kPa (per unit of the parameter).

        Returns
        -------
        ndarray, shape (n_dofs,)
            mN (per unit of the parameter).
        """
        nel, nq = self.r.shape
        fe = np.matmul(self._GeT, (P5 * self.dV).transpose(1, 0, 2).reshape(nel, 5 * nq, 1))[:, :, 0]
        return np.bincount(self.element_dofs.T.ravel(), weights=fe.ravel(), minlength=self.n_dofs)

    def tangent(self, u: np.ndarray) -> np.ndarray:
        """Element tangents (nel, nloc, nloc) at ``u``, reusing the kinematics of the last
        :meth:`forces` call when it was at the same ``u`` (the usual Newton sequence:
        residual first, tangent only when the iteration goes on)."""
        if self._cache is not None and np.array_equal(self._cache[0], u):
            H = self._cache[1]
        else:
            H = self.displacement_gradient(u)
        return self._element_tangents(self._material_loop(H, True)[1])

    def _element_tangents(self, A55: np.ndarray) -> np.ndarray:
        """K_e[k, l] = sum_q sum_cd G[c, k] A[c, d] G[d, l] dV, from the tangent components (5, 5, nel, nq)."""
        # B = A G dV per quadrature point, using the block structure of G (components
        # 0, 1, 4 act on u_r dofs only, 2, 3 on u_z dofs only), then one
        # (nloc x 5nq) @ (5nq x nloc) product per element.
        nel, nq = self.r.shape
        AdV = A55 * self.dV
        B = np.empty((nel, 5, nq, self._GeT.shape[1]))
        for c in range(5):
            Ar = AdV[c, 0][..., None] * self._G_r[0]
            Ar += AdV[c, 1][..., None] * self._G_r[1]
            Ar += AdV[c, 4][..., None] * self._G_r[2]
            Az = AdV[c, 2][..., None] * self._G_z[0]
            Az += AdV[c, 3][..., None] * self._G_z[1]
            B[:, c, :, :self._nr] = Ar
            B[:, c, :, self._nr:] = Az
        return np.matmul(self._GeT, B.reshape(nel, 5 * nq, -1))

    def stress_fields(self, u: np.ndarray) -> dict[str, np.ndarray]:
        """Element averages of the Cauchy stress (kPa) and von Mises stress.

        Returns a dict with ``cauchy_rr, cauchy_zz, cauchy_tt, cauchy_rz, von_mises``
        of shape (nel,).
        """
        F = self.displacement_gradient(u)
        sig = np.empty((3, 3) + F.shape[2:])
        for (ix, _), mat in zip(self.regions, self._active):
            H = F[:, :, ix]
            sig[:, :, ix] = cauchy_stress(mat.stress(H), H, self.small_strain)
        w = self.basis.dx / self.basis.dx.sum(axis=1, keepdims=True)
        avg = lambda a: np.sum(a * w, axis=1)  # noqa: E731
        s = {
            "cauchy_rr": avg(sig[0, 0]),
            "cauchy_zz": avg(sig[1, 1]),
            "cauchy_tt": avg(sig[2, 2]),
            "cauchy_rz": avg(0.5 * (sig[0, 1] + sig[1, 0])),
        }
        vm = np.sqrt(
            0.5 * ((sig[0, 0] - sig[1, 1]) ** 2 + (sig[1, 1] - sig[2, 2]) ** 2 + (sig[2, 2] - sig[0, 0]) ** 2)
            + 3.0 * (0.5 * (sig[0, 1] + sig[1, 0])) ** 2
        )
        s["von_mises"] = avg(vm)
        return s
