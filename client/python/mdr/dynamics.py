"""The harmonic-balance element (docs/dynamics.md): an exact contact, or a rough interface's
asperities under a shared motion, pressed to a constant normal force, whose steady periodic force
and its exact Jacobian come from one call per Newton iteration, in this process (libmdr_c).

    import numpy as np, mdr.dynamics
    element = mdr.dynamics.ContactElement(H1, normal_force=100)
    h = np.arange(6)                                     # harmonics 0 .. 5
    U = np.zeros(11); U[1] = 2e-7                        # [U0, U1c, U1s, U2c, U2s, ...], m
    F, dFdU, energy = element.aft(U, h, samples=128)     # N, N/m (11 x 11), J per period

Convention (tmdsimpy's and NLvib's): u(tau) = U0 + sum_h U_h^c cos(h tau) + U_h^s sin(h tau),
tau = omega t, sampled at tau_j = 2 pi j / Nt; the force is the contact's F_x, an internal force
resisting the motion, in the same form. The element is rate-independent: dF/domega = 0.

TmdsimpyForce wraps an element in the method set tmdsimpy's solvers call on a hysteretic
nonlinear force (nl_force_type, aft(U, w, h, Nt, tol, calc_grad), force), so that a
tmdsimpy.VibrationSystem takes it with add_nl_force.
"""
from __future__ import annotations

import ctypes
from typing import Optional, Tuple

import grpc
import numpy as np

from . import inprocess, messages
from .errors import MdrError

__all__ = ["ContactElement", "TmdsimpyForce", "coefficient_count"]


def coefficient_count(harmonics) -> int:
    """The coefficients of a harmonic list: 1 for harmonic 0, 2 for every other (tmdsimpy's Nhc)."""
    h = np.asarray(harmonics)
    return int((h == 0).sum() + 2 * (h != 0).sum())


class ContactElement:
    """A contact element pressed once to `normal_force` (N, > 0): a scene of one contact, or of an
    interface with kind "shared_motion" (the force its total). Every aft() starts from that
    pressed state; the element itself never changes."""

    def __init__(self, scene, normal_force: float, library: Optional[str] = None):
        self._lib = inprocess.load_library(library)
        if not hasattr(self._lib, "mdr_element_create"):
            raise ImportError("libmdr_c has no harmonic-balance element (revision 4): rebuild or "
                              "reinstall it with the package")
        data = messages.to_scene(scene).SerializeToString()
        handle = ctypes.c_void_p()
        inprocess.check(self._lib, self._lib.mdr_element_create(
            data, len(data), float(normal_force), ctypes.byref(handle)))
        self._handle = handle

    def close(self) -> None:
        if self._handle:
            self._lib.mdr_element_destroy(self._handle)
            self._handle = None

    def __enter__(self) -> "ContactElement":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        self.close()

    def aft(self, U, harmonics, samples: int = 128,
            jacobian: bool = True) -> Tuple[np.ndarray, Optional[np.ndarray], float]:
        """The steady force's coefficients for the displacement's U (m), their Jacobian dF/dU
        (N/m, (n, n); None without `jacobian`) and the energy dissipated per period (J)."""
        if not self._handle:
            raise MdrError(grpc.StatusCode.FAILED_PRECONDITION, "element", "the element is closed")
        u = np.ascontiguousarray(U, dtype=np.float64)
        h = np.ascontiguousarray(harmonics, dtype=np.int32)
        n = u.size
        force = np.empty(n)
        dfdu = np.empty((n, n)) if jacobian else None
        energy = ctypes.c_double()
        dbl = ctypes.POINTER(ctypes.c_double)
        inprocess.check(self._lib, self._lib.mdr_element_aft(
            self._handle, u.ctypes.data_as(dbl), n,
            h.ctypes.data_as(ctypes.POINTER(ctypes.c_int32)), h.size, int(samples),
            force.ctypes.data_as(dbl), dfdu.ctypes.data_as(dbl) if jacobian else None,
            ctypes.byref(energy)))
        return force, dfdu, energy.value


class TmdsimpyForce:
    """tmdsimpy's hysteretic nonlinear force over a ContactElement. Q (1, N) takes the system's N
    degrees of freedom to the contact's tangential displacement, T (N, 1) its force back (each
    harmonic component alike, as tmdsimpy orders them: every DOF of a component, then the
    next)."""

    def __init__(self, Q, T, element: ContactElement):
        self.Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
        self.T = np.asarray(T, dtype=np.float64).reshape(-1, 1)
        if self.Q.shape[0] != 1 or self.T.shape[0] != self.Q.shape[1]:
            raise ValueError("Q must be (1, N) and T (N, 1): the element has one displacement")
        self.element = element

    def nl_force_type(self) -> int:
        """1: a hysteretic force (its force depends on the history, not the instant)."""
        return 1

    def aft(self, U, w, h, Nt=128, tol=1e-7, calc_grad=True):
        """(Fnl, dFnldU, dFnldw) in the system's harmonic DOFs; (Fnl,) without calc_grad. w and
        tol are ignored: the element is rate-independent and its loop is steady exactly."""
        del w, tol
        n = self.Q.shape[1]
        nhc = coefficient_count(h)
        u_global = np.asarray(U, dtype=np.float64).reshape(nhc, n)
        u_local = u_global @ self.Q[0]
        f_local, dfdu_local, _ = self.element.aft(u_local, h, Nt, jacobian=calc_grad)
        fnl = (f_local[:, None] * self.T[:, 0][None, :]).reshape(-1)
        if not calc_grad:
            return (fnl,)
        # dFnl[(k, i)] / dU[(l, j)] = T_i dF_kl Q_j
        dfnldu = np.einsum("kl,i,j->kilj", dfdu_local, self.T[:, 0], self.Q[0]).reshape(
            nhc * n, nhc * n)
        return fnl, dfnldu, np.zeros(nhc * n)

    def force(self, X, update_hist=False):
        """A static evaluation (tmdsimpy's prestress): the force of the pressed contact moved
        from u = 0 to Q X along the virgin curve, and its stiffness there; no history is kept."""
        del update_hist
        u = float(self.Q[0] @ np.asarray(X, dtype=np.float64))
        f, dfdu, _ = self.element.aft(np.array([u]), np.array([0]), 8)
        return self.T[:, 0] * f[0], np.outer(self.T[:, 0], self.Q[0]) * dfdu[0, 0]
