"""Craig-Bampton reduction of one substructure (SPEC section 2, "Reduction").

    x = [x_b]  =  [ I      0   ] [x_b]
        [x_i]     [ Psi    Phi ] [eta]        Psi = -K_ii^-1 K_ib   (static constraint modes)
                                              Phi: fixed-interface modes, K_ii Phi = M_ii Phi Omega^2

Boundary DOFs x_b stay physical; eta are the modal amplitudes of the interior with the
boundary held fixed, kept up to a cut-off frequency.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla


def craig_bampton(K: np.ndarray, M: np.ndarray, boundary: np.ndarray, cutoff_hz: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Craig-Bampton basis T (n x (n_b + n_modes)), columns ordered [boundary, modes].

    Parameters: K, M [SI] symmetric (constrained DOFs already removed); boundary: indices of
    the kept physical DOFs; cutoff_hz [Hz]: fixed-interface modes up to this frequency.
    Returns (T, fixed-interface frequencies kept [Hz]).
    """
    n = K.shape[0]
    b = np.asarray(boundary, dtype=np.int64)
    i = np.setdiff1d(np.arange(n), b)
    T = np.zeros((n, len(b)))
    T[b, np.arange(len(b))] = 1.0
    if len(i) == 0:
        return T, np.zeros(0)
    # --- static constraint modes: K_ii Psi = -K_ib
    Kii = K[np.ix_(i, i)]
    Psi = -sla.solve(Kii, K[np.ix_(i, b)], assume_a="pos")
    T[np.ix_(i, np.arange(len(b)))] = Psi
    # --- fixed-interface normal modes below the cut-off
    lam, Phi = sla.eigh(Kii, M[np.ix_(i, i)], subset_by_value=(-np.inf, (2 * np.pi * cutoff_hz) ** 2))
    Tm = np.zeros((n, len(lam)))
    Tm[i, :] = Phi
    return np.hstack([T, Tm]), np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
