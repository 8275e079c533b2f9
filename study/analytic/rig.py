"""Physical test rig <-> dimensionless model (paper Eq. 1-8, 28-30).

Plain vectorised numpy functions (SI units), plus a small frozen dataclass ``Rig`` that bundles
them for one rig.  Contact law ``F = k z**n`` (``n = 3/2``: Hertz point contact of the paper;
``n = 1``: linear impact oscillator; ``n = 10/9``: line contact), generalising the paper::

    z_s     = (N / k)**(1/n)                     (Eq. 2,  n = 3/2: (N/k)**(2/3))
    Omega**2 = k n z_s**(n-1) / m                (Eq. 3,  n = 3/2: (3k/2m) z_s**(1/2))
    zeta    = c / (2 m Omega)                    (Eq. 4)
    q       = n (z - z_s) / z_s                  (Eq. 5,  n = 3/2: 3 (z - z_s) / (2 z_s))
    tau     = Omega t                            (Eq. 6)
    omega   = omega_phys / Omega = 2 pi f / Omega  (Eq. 8)
    sigma   = force amplitude / N                (Eq. 1)
    F_exp   = (F - N) / N                        (Eq. 30)

With these, Eq. 1 becomes Eq. 7 with the restoring force ``(1 + q/n)**n`` and contact loss at
``q = -n``.

Hertz constants for identical materials (effective modulus ``E* = E / (2 (1 - nu**2))``,
single sphere-plane contact ``F = (4/3) E* sqrt(R) delta**(3/2)``):

* single sphere-plane: ``k = (4/3) E* sqrt(R) = 2 E sqrt(R) / (3 (1 - nu**2))``
* double sphere-plane (ball between two flats, paper Eq. 28): the two contacts are in series
  and each is compressed by ``z/2``, so ``k = k_single / 2**(3/2) = E sqrt(R) / (3 sqrt(2) (1 - nu**2))``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "hertz_constant",
    "static_compression",
    "natural_circular_frequency",
    "natural_frequency",
    "frequency_to_omega",
    "omega_to_frequency",
    "force_amplitude_to_sigma",
    "sigma_to_force_amplitude",
    "damping_to_zeta",
    "zeta_to_damping",
    "displacement_to_q",
    "q_to_displacement",
    "time_to_tau",
    "tau_to_time",
    "force_to_fexp",
    "fexp_to_force",
    "restoring_force",
    "Rig",
]

_GEOMETRIES = ("double", "single")


# ---------------------------------------------------------------------------------------------
# input checks
# ---------------------------------------------------------------------------------------------

def _positive(x, name, unit):
    a = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(a) & (a > 0.0)):
        raise ValueError(f"{name} must be finite and > 0 [{unit}], got {x!r}")
    return a


def _poisson(nu):
    a = np.asarray(nu, dtype=float)
    if not np.all(np.isfinite(a) & (a > -1.0) & (a <= 0.5)):
        raise ValueError(f"nu (Poisson ratio) must be in (-1, 0.5], got {nu!r}")
    return a


def _exponent(n):
    return _positive(n, "n (contact exponent)", "-")


# ---------------------------------------------------------------------------------------------
# rig constants
# ---------------------------------------------------------------------------------------------

def hertz_constant(E, nu, R, contact="double"):
    """Hertz constant ``k`` of ``F = k z**(3/2)`` for identical materials [N m^-3/2].

    Parameters
    ----------
    E : array_like
        Young's modulus [Pa], > 0.
    nu : array_like
        Poisson ratio [-], in (-1, 0.5].
    R : array_like
        Ball radius [m], > 0.
    contact : {"double", "single"}
        "double": ball between two flats, paper Eq. 28, ``E sqrt(R) / (3 sqrt(2) (1 - nu**2))``.
        "single": one sphere-plane contact, ``(4/3) E* sqrt(R)``, ``E* = E / (2 (1 - nu**2))``.

    Returns
    -------
    k : ndarray
        [N m^-3/2].  Paper rig (E = 210 GPa, nu = 0.29, R = 12.7 mm, double): 6.09e9 (Eq. 29a: 6.1e9).
    """
    E = _positive(E, "E (Young's modulus)", "Pa")
    nu = _poisson(nu)
    R = _positive(R, "R (ball radius)", "m")
    e_star = E / (2.0 * (1.0 - nu**2))
    k_single = 4.0 / 3.0 * e_star * np.sqrt(R)
    if contact == "single":
        return k_single
    if contact == "double":
        return k_single / 2.0**1.5
    raise ValueError(f"contact must be one of {_GEOMETRIES}, got {contact!r}")


def static_compression(N, k, n=1.5):
    """Static compression ``z_s = (N / k)**(1/n)``, paper Eq. 2 [m].

    Parameters
    ----------
    N : array_like
        Static load [N], > 0.
    k : array_like
        Contact constant [N m^-n], > 0.
    n : array_like
        Contact exponent [-], > 0 (3/2 for Hertz).
    """
    N = _positive(N, "N (static load)", "N")
    k = _positive(k, "k (contact constant)", "N m^-n")
    n = _exponent(n)
    return (N / k) ** (1.0 / n)


def natural_circular_frequency(N, k, m, n=1.5):
    """Linearised natural circular frequency ``Omega = sqrt(k n z_s**(n-1) / m)``, paper Eq. 3 [rad/s].

    Equivalently ``Omega**2 = n N / (m z_s)`` (the contact stiffness ``n N / z_s`` over the mass).
    """
    m = _positive(m, "m (moving mass)", "kg")
    z_s = static_compression(N, k, n)
    n = _exponent(n)
    return np.sqrt(np.asarray(k, float) * n * z_s ** (n - 1.0) / m)


def natural_frequency(N, k, m, n=1.5):
    """``f0 = Omega / (2 pi)``, paper Eq. 29c [Hz]."""
    return natural_circular_frequency(N, k, m, n) / (2.0 * np.pi)


# ---------------------------------------------------------------------------------------------
# conversions (Omega, N, m, z_s given)
# ---------------------------------------------------------------------------------------------

def frequency_to_omega(f, Omega):
    """Excitation frequency [Hz] -> ``omega = 2 pi f / Omega``, paper Eq. 8 [-]."""
    return 2.0 * np.pi * np.asarray(f, float) / _positive(Omega, "Omega", "rad/s")


def omega_to_frequency(omega, Omega):
    """``omega`` [-] -> excitation frequency ``f = omega Omega / (2 pi)`` [Hz] (inverse of Eq. 8)."""
    return np.asarray(omega, float) * _positive(Omega, "Omega", "rad/s") / (2.0 * np.pi)


def force_amplitude_to_sigma(F_amp, N):
    """Dynamic force amplitude [N] -> ``sigma = F_amp / N`` (Eq. 1) [-]."""
    return np.asarray(F_amp, float) / _positive(N, "N (static load)", "N")


def sigma_to_force_amplitude(sigma, N):
    """``sigma`` [-] -> dynamic force amplitude ``sigma N`` [N] (Eq. 1)."""
    return np.asarray(sigma, float) * _positive(N, "N (static load)", "N")


def damping_to_zeta(c, m, Omega):
    """Viscous damping coefficient ``c`` [N s/m] -> ``zeta = c / (2 m Omega)``, paper Eq. 4 [-]."""
    return np.asarray(c, float) / (2.0 * _positive(m, "m (moving mass)", "kg")
                                   * _positive(Omega, "Omega", "rad/s"))


def zeta_to_damping(zeta, m, Omega):
    """``zeta`` [-] -> ``c = 2 m Omega zeta`` [N s/m] (inverse of Eq. 4)."""
    return 2.0 * _positive(m, "m (moving mass)", "kg") * _positive(Omega, "Omega", "rad/s") \
        * np.asarray(zeta, float)


def displacement_to_q(z, z_s, n=1.5):
    """Displacement ``z`` [m] (z < 0: contact lost) -> ``q = n (z - z_s) / z_s``, paper Eq. 5 [-]."""
    z_s = _positive(z_s, "z_s (static compression)", "m")
    return _exponent(n) * (np.asarray(z, float) - z_s) / z_s


def q_to_displacement(q, z_s, n=1.5):
    """``q`` [-] -> displacement ``z = z_s (1 + q / n)`` [m] (inverse of Eq. 5)."""
    z_s = _positive(z_s, "z_s (static compression)", "m")
    return z_s * (1.0 + np.asarray(q, float) / _exponent(n))


def time_to_tau(t, Omega):
    """Time [s] -> ``tau = Omega t``, paper Eq. 6 [-]."""
    return _positive(Omega, "Omega", "rad/s") * np.asarray(t, float)


def tau_to_time(tau, Omega):
    """``tau`` [-] -> time ``t = tau / Omega`` [s] (inverse of Eq. 6)."""
    return np.asarray(tau, float) / _positive(Omega, "Omega", "rad/s")


def force_to_fexp(F, N):
    """Contact force ``F`` [N] -> ``F_exp = (F - N) / N``, paper Eq. 30 [-] (contact lost at -1)."""
    N = _positive(N, "N (static load)", "N")
    return (np.asarray(F, float) - N) / N


def fexp_to_force(F_exp, N):
    """``F_exp`` [-] -> contact force ``F = N (1 + F_exp)`` [N] (inverse of Eq. 30)."""
    return _positive(N, "N (static load)", "N") * (1.0 + np.asarray(F_exp, float))


def restoring_force(q, n=1.5):
    """Dimensionless contact force ``F / N = (1 + q/n)**n`` for ``q >= -n``, 0 below (paper Eq. 7).

    ``F_exp = restoring_force(q, n) - 1`` (Eq. 30).
    """
    n = _exponent(n)
    q = np.asarray(q, float)
    base = np.maximum(1.0 + q / n, 0.0)
    return base**n


# ---------------------------------------------------------------------------------------------
# Rig dataclass
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Rig:
    """One rig: contact constant ``k`` [N m^-n], mass ``m`` [kg], static load ``N`` [N], exponent ``n``.

    Build from material data with ``Rig.hertz(E, nu, R, m, N, contact="double")`` (n = 3/2),
    or ``Rig.paper()`` for the paper's rig.  All methods are the module functions bound to
    this rig's ``z_s``, ``Omega``, ``m``, ``N``, ``n``.
    """

    k: float
    m: float
    N: float
    n: float = 1.5

    def __post_init__(self):
        _positive(self.k, "k (contact constant)", "N m^-n")
        _positive(self.m, "m (moving mass)", "kg")
        _positive(self.N, "N (static load)", "N")
        _exponent(self.n)
        for name in ("k", "m", "N", "n"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @classmethod
    def hertz(cls, E, nu, R, m, N, contact="double"):
        """Rig with the Hertz constant of identical materials (``hertz_constant``), n = 3/2."""
        return cls(k=float(hertz_constant(E, nu, R, contact)), m=m, N=N, n=1.5)

    @classmethod
    def paper(cls):
        """The paper's rig: E = 210 GPa, nu = 0.29, R = 12.7 mm, m = 7.1 kg, N = 69.7 N, double contact."""
        from hertzmap.study.analytic import paper as pc

        return cls.hertz(pc.E, pc.NU, pc.R, pc.M, pc.N, contact="double")

    @property
    def z_s(self) -> float:
        """Static compression [m] (Eq. 2)."""
        return float(static_compression(self.N, self.k, self.n))

    @property
    def Omega(self) -> float:
        """Linearised natural circular frequency [rad/s] (Eq. 3)."""
        return float(natural_circular_frequency(self.N, self.k, self.m, self.n))

    @property
    def f0(self) -> float:
        """Linearised natural frequency [Hz] (Eq. 29c)."""
        return self.Omega / (2.0 * np.pi)

    @property
    def stiffness(self) -> float:
        """Linearised contact stiffness ``n N / z_s = m Omega**2`` [N/m]."""
        return self.n * self.N / self.z_s

    def frequency_to_omega(self, f):
        return frequency_to_omega(f, self.Omega)

    def omega_to_frequency(self, omega):
        return omega_to_frequency(omega, self.Omega)

    def force_amplitude_to_sigma(self, F_amp):
        return force_amplitude_to_sigma(F_amp, self.N)

    def sigma_to_force_amplitude(self, sigma):
        return sigma_to_force_amplitude(sigma, self.N)

    def damping_to_zeta(self, c):
        return damping_to_zeta(c, self.m, self.Omega)

    def zeta_to_damping(self, zeta):
        return zeta_to_damping(zeta, self.m, self.Omega)

    def displacement_to_q(self, z):
        return displacement_to_q(z, self.z_s, self.n)

    def q_to_displacement(self, q):
        return q_to_displacement(q, self.z_s, self.n)

    def time_to_tau(self, t):
        return time_to_tau(t, self.Omega)

    def tau_to_time(self, tau):
        return tau_to_time(tau, self.Omega)

    def force_to_fexp(self, F):
        return force_to_fexp(F, self.N)

    def fexp_to_force(self, F_exp):
        return fexp_to_force(F_exp, self.N)

    def contact_force(self, z):
        """Contact force ``k z**n`` for z >= 0, 0 below [N]."""
        z = np.asarray(z, float)
        return self.k * np.maximum(z, 0.0) ** self.n
