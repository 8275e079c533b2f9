"""Order-2 subharmonic resonance by the method of multiple scales (paper section 3.1).

Plain, vectorised numpy functions: every argument broadcasts against the others
and the result has the broadcast shape (a 0-d input gives a numpy scalar / 0-d array).

Model (paper Eq. 11, the third-order Taylor model of the Hertz contact)::

    q'' + 2 zeta q' + q + q**2/6 - q**3/54 = sigma cos(omega tau)

All quantities are dimensionless: ``q`` is the displacement of Eq. 5 (``q = 3 (z - z_s) / (2 z_s)``),
``tau = Omega t`` (Eq. 6), ``omega`` is the excitation frequency over the linearised natural
frequency (Eq. 8), ``zeta`` the damping ratio (Eq. 4), ``sigma`` the excitation amplitude
over the static load (Eq. 1).

How the small parameter eps is absorbed
---------------------------------------
The paper orders ``q = eps q^, zeta = eps zeta^, sigma = eps sigma^`` (Eq. 13) and
``omega = 2 + eps lambda`` (Eq. 18).  Every term of the reconstituted amplitude equation is
homogeneous in those scalings (each term of order eps^k in the hat variables carries exactly
the powers of eps that turn hat variables back into physical ones, and ``lambda`` always appears
as ``eps lambda``).  So setting eps = 1 and reading ``q, A, B, zeta, sigma`` as the *unscaled*
(physical, dimensionless) variables is exact bookkeeping, not an extra approximation, provided
the detuning is read as::

    lambda = omega - 2            (Eq. 18 with eps = 1)

That is what every function here does.  Coefficients that the paper keeps as functions of the
exact ``omega`` (``1 - omega**2``, ``omega (omega + 2)``, ...) are evaluated at the exact omega.

Variants
--------
Two formulas of the OCR'd paper disagree with a re-derivation of the second-order
multiple-scales result (see ``docs/analytic.md`` for the derivation outline and numbers):

* Eq. 22 (gamma): printed ``(1/9)(omega**2 + 2 omega) B**2``; the derivation gives
  ``B**2 / (9 (omega**2 + 2 omega))`` (a fraction flattened by OCR).  The numerically exact
  flip curve of Eq. 11 confirms the derived version.
* Eq. 21 (phase): the last term of the denominator is printed ``zeta omega``; the derivation
  gives ``2 zeta omega``.  Also, ``tan(phi)`` fixes phi only modulo pi, while the response
  (Eq. 19) needs phi modulo 2 pi; the derived phase is returned by ``atan2``.

Functions taking ``variant`` accept ``"derived"`` (default, the re-derived formula) or
``"paper"`` (the formula exactly as printed in the OCR'd text).

Branches
--------
``branch="upper"`` (or ``"+"``) is the ``+`` root of Eq. 23 (the stable subharmonic),
``branch="lower"`` (or ``"-"``) the ``-`` root (unstable where both exist, i.e. in region II),
``branch="trivial"`` is A = 0 (the 1T response, first order).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "detuning",
    "b_coefficient",
    "gamma",
    "beta",
    "amplitude_squared",
    "amplitude",
    "phase",
    "response",
    "mms_2t_seed",
    "min_response",
    "sigma1",
    "sigma2",
    "sigma_star",
    "region",
    "REGION_I",
    "REGION_II",
    "REGION_III",
]

REGION_I = 1    # sigma > sigma2: trivial (1T) response unstable, one stable subharmonic
REGION_II = 2   # sigma1 < sigma < sigma2 on the softening side: 1T stable + two subharmonics
REGION_III = 3  # no subharmonic response

_VARIANTS = ("derived", "paper")


def _check_variant(variant):
    if variant not in _VARIANTS:
        raise ValueError(f"variant must be one of {_VARIANTS}, got {variant!r}")


def _branch_sign(branch):
    if branch in ("upper", "+", +1):
        return 1.0
    if branch in ("lower", "-", -1):
        return -1.0
    if branch in ("trivial", 0):
        return 0.0
    raise ValueError(f"branch must be 'upper' ('+'), 'lower' ('-') or 'trivial', got {branch!r}")


def _f(x):
    return np.asarray(x, dtype=float)


def _quiet(func):
    """Evaluate without floating-point warnings: out-of-domain points (omega = 1, sigma < sigma1,
    zeta = 0 in a division, ...) are documented to give inf/NaN, not warnings."""
    import functools

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return func(*args, **kwargs)

    return wrapper


# ---------------------------------------------------------------------------------------------
# Coefficients
# ---------------------------------------------------------------------------------------------

def detuning(omega):
    """Detuning ``lambda = omega - 2`` (paper Eq. 18 with eps = 1).

    Parameters
    ----------
    omega : array_like
        Dimensionless excitation circular frequency (Eq. 8) [-].

    Returns
    -------
    lambda : ndarray
        Detuning [-].
    """
    return _f(omega) - 2.0


@_quiet
def b_coefficient(omega, sigma):
    """Amplitude ``B`` of the forced (1T) component, paper Eq. 20.

    ``B = sigma / (2 (1 - omega**2))``.  The 1T part of the response is ``2 B cos(omega tau)``
    (Eq. 19), so ``2 B`` is the linear forced amplitude [-]; ``B < 0`` for ``omega > 1``.

    Parameters
    ----------
    omega : array_like
        Excitation frequency (Eq. 8) [-]; ``omega = 1`` gives inf/nan.
    sigma : array_like
        Excitation level (Eq. 1) [-].

    Returns
    -------
    B : ndarray
        [-].
    """
    omega = _f(omega)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _f(sigma) / (2.0 * (1.0 - omega**2))


@_quiet
def gamma(omega, sigma, zeta, variant="derived"):
    """Frequency shift ``gamma`` of the subharmonic, paper Eq. 22 [-].

    derived (default)::

        gamma = [-7/36 + 1 / (9 (omega**2 + 2 omega))] B**2 - zeta**2

    paper (as printed, OCR)::

        gamma = [-7/36 + (1/9) (omega**2 + 2 omega)] B**2 - zeta**2

    The ``1/(9 omega (omega + 2))`` term comes from the ``cos((3 omega tau - phi)/2)``
    component of Eq. 19, whose amplitude has the same ``omega (omega + 2)`` in the denominator.
    At omega = 2 the bracket is -13/72 (derived) against +25/36 (paper).

    Parameters
    ----------
    omega, sigma, zeta : array_like
        Frequency (Eq. 8), excitation level, damping ratio (Eq. 4) [-].
    variant : {"derived", "paper"}

    Returns
    -------
    gamma : ndarray
        [-].
    """
    _check_variant(variant)
    omega = _f(omega)
    b2 = b_coefficient(omega, sigma) ** 2
    w2w = omega**2 + 2.0 * omega
    if variant == "derived":
        with np.errstate(divide="ignore", invalid="ignore"):
            c = -7.0 / 36.0 + 1.0 / (9.0 * w2w)
    else:
        c = -7.0 / 36.0 + w2w / 9.0
    return c * b2 - _f(zeta) ** 2


@_quiet
def beta(omega, zeta):
    """Parametric-excitation coefficient ``beta``, paper Eq. 24 [-].

    ``beta = 1/(omega**2 - 1) * [ (1 - lambda/2)**2 / 36 + (zeta omega / (3 omega**2 - 3))**2 ]**(1/2)``
    with ``lambda = omega - 2``.  ``|beta| sigma`` is the modulus of the coefficient of
    ``conj(A) exp(i lambda tau)`` in the amplitude equation; it was re-derived and agrees
    with the printed formula.  At omega = 2: ``beta = sqrt(1 + 16 zeta**2 / 9) / 18``.

    Parameters
    ----------
    omega, zeta : array_like
        [-].

    Returns
    -------
    beta : ndarray
        [-]; negative for omega < 1 (only ``|beta|`` is used).
    """
    omega = _f(omega)
    lam = detuning(omega)
    with np.errstate(divide="ignore", invalid="ignore"):
        w21 = omega**2 - 1.0
        return np.sqrt((1.0 - lam / 2.0) ** 2 / 36.0 + (_f(zeta) * omega / (3.0 * w21)) ** 2) / w21


# ---------------------------------------------------------------------------------------------
# Frequency response (Eq. 23) and phase (Eq. 21)
# ---------------------------------------------------------------------------------------------

@_quiet
def amplitude_squared(omega, sigma, zeta, branch="upper", variant="derived"):
    """``A**2`` from the frequency-response equation, paper Eq. 23.

    ``A**2 / 27 = (gamma - lambda) +/- (beta**2 sigma**2 - 4 zeta**2)**(1/2)``

    NaN where the square root is not real (``sigma < sigma1``).  May be negative (that root is
    then not a response).  ``branch="trivial"`` gives 0.

    Returns
    -------
    A2 : ndarray
        [-].
    """
    s = _branch_sign(branch)
    omega = _f(omega)
    sigma = _f(sigma)
    zeta = _f(zeta)
    lam = detuning(omega)
    g = gamma(omega, sigma, zeta, variant)
    disc = beta(omega, zeta) ** 2 * sigma**2 - 4.0 * zeta**2
    with np.errstate(invalid="ignore"):
        root = np.sqrt(disc)            # nan where disc < 0
    a2 = 27.0 * ((g - lam) + s * root)
    if s == 0.0:
        a2 = np.zeros_like(a2)
    return a2


@_quiet
def amplitude(omega, sigma, zeta, branch="upper", variant="derived"):
    """Amplitude ``A`` of the half-frequency component, paper Eq. 23 [-].

    ``A >= 0`` is the amplitude of ``A cos((omega tau - phi)/2)`` in Eq. 19 (the peak value of the
    subharmonic component of q).  NaN where Eq. 23 has no real non-negative root on that branch.

    Parameters
    ----------
    omega, sigma, zeta : array_like
        [-].
    branch : {"upper", "+", "lower", "-", "trivial"}
        ``+`` or ``-`` root of Eq. 23; "trivial" returns 0.
    variant : {"derived", "paper"}
        Which gamma (Eq. 22) to use.

    Returns
    -------
    A : ndarray
        [-], NaN where not real.
    """
    a2 = amplitude_squared(omega, sigma, zeta, branch, variant)
    with np.errstate(invalid="ignore"):
        return np.where(a2 >= 0.0, np.sqrt(np.where(a2 >= 0.0, a2, 0.0)), np.nan)


@_quiet
def phase(omega, sigma, zeta, branch="upper", variant="derived"):
    """Phase ``phi`` of the subharmonic component, paper Eq. 21 [rad].

    derived (default): phi modulo 2 pi from the re-derived steady-state amplitude-phase equations::

        Gamma B exp(i phi) = (lambda - gamma + A**2/27) - 2 i zeta,
        Gamma = (1 - lambda/2)/3 + 2 i zeta omega / (3 (omega**2 - 1)),

    which give Eq. 23 (modulus) and the tangent::

        tan phi = [(omega**2-1)(lambda/2-1) - omega P] / [(1-omega**2)(lambda/2-1) P / (2 zeta) - 2 zeta omega],
        P = lambda - gamma + A**2/27,

    i.e. Eq. 21 with ``2 zeta omega`` in place of the printed ``zeta omega``.  Returned in (-pi, pi].

    paper: Eq. 21 exactly as printed (``zeta omega``, paper gamma), ``arctan`` principal value in
    (-pi/2, pi/2).  Tan only fixes phi modulo pi, so half the time this is the wrong orbit
    (phi + pi is *not* the T-shifted copy, phi + 2 pi is); do not use it to seed.

    NaN where ``A`` is NaN.  For ``branch="trivial"`` the phase is undefined (NaN).

    Returns
    -------
    phi : ndarray
        [rad].
    """
    _check_variant(variant)
    s = _branch_sign(branch)
    omega = _f(omega)
    sigma = _f(sigma)
    zeta = _f(zeta)
    lam = detuning(omega)
    a = amplitude(omega, sigma, zeta, branch, variant)
    if s == 0.0:
        return np.full(np.broadcast(omega, sigma, zeta).shape, np.nan)[()]
    p = lam - gamma(omega, sigma, zeta, variant) + a**2 / 27.0
    with np.errstate(divide="ignore", invalid="ignore"):
        if variant == "paper":
            num = (omega**2 - 1.0) * (lam / 2.0 - 1.0) - omega * p
            den = (1.0 - omega**2) * (lam / 2.0 - 1.0) * p / (2.0 * zeta) - zeta * omega
            return np.arctan(num / den)
        gr = (1.0 - lam / 2.0) / 3.0
        gi = 2.0 * zeta * omega / (3.0 * (omega**2 - 1.0))
        bsign = np.sign(b_coefficient(omega, sigma))
        # exp(i phi) = (p - 2 i zeta) conj(Gamma) / (B |Gamma|^2)
        re = (p * gr - 2.0 * zeta * gi) * bsign
        im = -(p * gi + 2.0 * zeta * gr) * bsign
        phi = np.arctan2(im, re)
    return np.where(np.isnan(a), np.nan, phi)[()]


# ---------------------------------------------------------------------------------------------
# Reconstructed 2T response (Eq. 19)
# ---------------------------------------------------------------------------------------------

def _response_terms(tau, omega, sigma, zeta, branch, variant):
    omega = _f(omega)
    sigma = _f(sigma)
    zeta = _f(zeta)
    tau = _f(tau)
    b = b_coefficient(omega, sigma)
    if _branch_sign(branch) == 0.0:
        a = np.zeros(np.broadcast(omega, sigma, zeta).shape)
        phi = np.zeros_like(a)
    else:
        a = amplitude(omega, sigma, zeta, branch, variant)
        phi = phase(omega, sigma, zeta, branch, variant)
    # (amplitude, frequency multiplier of tau, phase offset) of each cosine term; q = c0 + sum c cos(k tau + d)
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = [
            (a, omega / 2.0, -phi / 2.0),                                           # A cos((w t - phi)/2)
            (2.0 * b, omega, 0.0),                                                   # 2B cos(w t)
            (a**2 / 36.0, omega, -phi),                                              # A^2/36 cos(w t - phi)
            (4.0 * zeta * omega * b / (1.0 - omega**2), omega, -np.pi / 2.0),       # ... sin(w t)
            (a * b / (3.0 * omega * (omega + 2.0)), 1.5 * omega, -phi / 2.0),        # cos((3 w t - phi)/2)
            (b**2 / (3.0 * (4.0 * omega**2 - 1.0)), 2.0 * omega, 0.0),              # cos(2 w t)
        ]
    c0 = -(b**2 + a**2 / 4.0) / 3.0
    return tau, c0, terms


@_quiet
def response(tau, omega, sigma, zeta, branch="upper", variant="derived"):
    """Reconstructed response ``q(tau)`` and ``dq/dtau`` of paper Eq. 19.

    ``q = -(B**2 + A**2/4)/3 + A cos((w tau - phi)/2) + 2 B cos(w tau) + A**2/36 cos(w tau - phi)
    + 4 zeta w B / (1 - w**2) sin(w tau) + A B / (3 w (w + 2)) cos((3 w tau - phi)/2)
    + B**2 / (3 (4 w**2 - 1)) cos(2 w tau)``

    (terms re-derived: they are ``q0 + q1`` of Eq. 16 a-b and agree with the print).
    Period ``4 pi / omega`` in tau (the 2T orbit, T = 2 pi / omega).

    Parameters
    ----------
    tau : array_like
        Dimensionless time (Eq. 6) [-]; broadcasts with the other arguments.
    omega, sigma, zeta : array_like
        [-].
    branch : {"upper", "lower", "trivial"}
    variant : {"derived", "paper"}
        Passed to ``amplitude`` and ``phase``.

    Returns
    -------
    q, dq : ndarray
        Displacement (Eq. 5) and its derivative d q / d tau [-]; NaN where A is NaN.
    """
    tau, c0, terms = _response_terms(tau, omega, sigma, zeta, branch, variant)
    q = c0
    dq = 0.0
    for amp, k, d in terms:
        arg = k * tau + d
        q = q + amp * np.cos(arg)
        dq = dq - amp * k * np.sin(arg)
    return q, dq


def _response_d2(tau, omega, sigma, zeta, branch, variant):
    tau, c0, terms = _response_terms(tau, omega, sigma, zeta, branch, variant)
    d2 = 0.0
    for amp, k, d in terms:
        d2 = d2 - amp * k * k * np.cos(k * tau + d)
    return d2


@_quiet
def mms_2t_seed(omega, sigma, zeta, branch="upper"):
    """Start point ``(q0, v0)`` at ``tau = 0`` of the MMS 2T response, to seed 2T shooting.

    ``q0, v0 = response(0, omega, sigma, zeta, branch)`` with the derived variant (correct phase
    modulo 2 pi).  The other copy of the same orbit (shifted by T) starts at
    ``response(2 pi / omega, ...)``.

    Parameters
    ----------
    omega, sigma, zeta : array_like
        [-].
    branch : {"upper", "lower"}
        ``+`` or ``-`` root of Eq. 23.

    Returns
    -------
    q0, v0 : ndarray
        [-]; NaN where that branch does not exist.
    """
    return response(0.0, omega, sigma, zeta, branch, "derived")


@_quiet
def min_response(omega, sigma, zeta, branch="upper", variant="derived", n=512):
    """Minimum of ``q(tau)`` of Eq. 19 over one 2T period (paper Fig. 5) [-].

    Sampled on ``n`` points of ``[0, 4 pi / omega)`` then refined by Newton steps on
    ``dq/dtau = 0`` (accurate to round-off).  Contact loss of the Taylor model (Eq. 12) where
    the result is below kernels.model.TAYLOR_CONTACT_LOSS (Eq. 12), of the Hertz model (Eq. 9) below -1.5.

    Returns
    -------
    qmin : ndarray
        [-], NaN where the branch does not exist.
    """
    omega, sigma, zeta = np.broadcast_arrays(_f(omega), _f(sigma), _f(zeta))
    shape = omega.shape
    w = omega[..., None]
    s = sigma[..., None]
    z = zeta[..., None]
    tau = np.arange(n) / n * (4.0 * np.pi / w)
    q, _ = response(tau, w, s, z, branch, variant)
    with np.errstate(invalid="ignore"):
        i = np.nanargmin(np.where(np.isnan(q), np.inf, q), axis=-1)
    t = np.take_along_axis(tau, i[..., None], axis=-1)
    h = 4.0 * np.pi / w / n
    for _ in range(8):
        _, dq = response(t, w, s, z, branch, variant)
        d2 = _response_d2(t, w, s, z, branch, variant)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(d2 > 0.0, -dq / d2, 0.0)
        t = t + np.clip(step, -h, h)
    q_ref, _ = response(t, w, s, z, branch, variant)
    qmin = np.minimum(np.nanmin(np.where(np.isnan(q), np.inf, q), axis=-1), q_ref[..., 0])
    qmin = np.where(np.isfinite(qmin), qmin, np.nan)
    return qmin.reshape(shape)[()]


# ---------------------------------------------------------------------------------------------
# Thresholds and regions (Eq. 25-27, Fig. 3)
# ---------------------------------------------------------------------------------------------

@_quiet
def sigma1(omega, zeta):
    """Saddle-node threshold ``sigma1 = 2 zeta / |beta|``, paper Eq. 25a [-].

    Below sigma1 the square root of Eq. 23 is not real: no subharmonic.  At omega = 2 this is
    ``36 zeta / sqrt(1 + 16 zeta**2 / 9)`` (compare Eq. 26).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        return 2.0 * _f(zeta) / np.abs(beta(omega, zeta))


@_quiet
def sigma2(omega, zeta, sigma=None, variant="derived"):
    """Flip (subharmonic bifurcation) threshold ``sigma2``, paper Eq. 25b [-].

    ``sigma2 = ((lambda - gamma)**2 + 4 zeta**2)**(1/2) / |beta|``.

    ``gamma`` depends on sigma (through ``B**2``), so Eq. 25b is implicit:

    * ``sigma=None`` (default): solve ``sigma = sigma2(sigma)`` exactly.  With
      ``gamma = c sigma**2 - zeta**2``, ``c = g(omega) / (4 (1 - omega**2)**2)``, it is a
      quadratic in ``s = sigma**2``:
      ``c**2 s**2 - (2 c (lambda + zeta**2) + beta**2) s + (lambda + zeta**2)**2 + 4 zeta**2 = 0``;
      the smallest non-negative root is returned (the one that tends to the first-order result
      ``sqrt(lambda**2 + 4 zeta**2)/|beta|`` as ``c -> 0``).  NaN if there is none.
      This is the sigma at which a root of Eq. 23 is exactly ``A = 0`` (the lower root where
      ``gamma > lambda``, i.e. on the softening side omega < ~2; the upper root otherwise).
    * ``sigma`` given: Eq. 25b evaluated with ``gamma(omega, sigma, zeta)`` (as printed).

    Parameters
    ----------
    omega, zeta : array_like
    sigma : array_like or None
    variant : {"derived", "paper"}
        Which gamma (Eq. 22).
    """
    _check_variant(variant)
    omega = _f(omega)
    zeta = _f(zeta)
    lam = detuning(omega)
    b = np.abs(beta(omega, zeta))
    if sigma is not None:
        g = gamma(omega, sigma, zeta, variant)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.sqrt((lam - g) ** 2 + 4.0 * zeta**2) / b
    # gamma = c * sigma^2 - zeta^2
    c = gamma(omega, 1.0, 0.0, variant)
    l2 = lam + zeta**2
    qa = c**2
    qb = -(2.0 * c * l2 + b**2)
    qc = l2**2 + 4.0 * zeta**2
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = qb**2 - 4.0 * qa * qc
        sq = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        # smallest positive root, stable form: s = 2 qc / (-qb + sq) when -qb > 0
        s_small = np.where(-qb > 0.0, 2.0 * qc / (-qb + sq), np.nan)
        s_small = np.where(qa == 0.0, qc / (-qb), s_small)
        s_small = np.where(s_small >= 0.0, s_small, np.nan)
        return np.sqrt(s_small)


def sigma_star(zeta, variant="paper"):
    """Threshold ``sigma*`` beyond which the subharmonic is always excited, paper Eq. 26-27 [-].

    variant:

    * ``"paper"`` (default): Eq. 26 as printed, ``36 zeta / (1 + 16 zeta**2 / 9)``.
    * ``"sigma1"``: ``sigma1(omega=2)`` from the paper's own beta (Eq. 24-25a),
      ``36 zeta / sqrt(1 + 16 zeta**2 / 9)`` (Eq. 26 looks like it lost a square root;
      the two differ by ``8 zeta**2 / 9`` relative, invisible for zeta << 1).
    * ``"small"``: Eq. 27, ``36 zeta``.
    * ``"min"``: the minimum over omega of the (derived, implicit) flip curve ``sigma2``, found
      numerically by a bounded scalar search near omega = 2 (loops over zeta; not vectorised).
    """
    zeta = _f(zeta)
    if variant == "paper":
        return 36.0 * zeta / (1.0 + 16.0 * zeta**2 / 9.0)
    if variant == "sigma1":
        return 36.0 * zeta / np.sqrt(1.0 + 16.0 * zeta**2 / 9.0)
    if variant == "small":
        return 36.0 * zeta
    if variant == "min":
        from scipy.optimize import minimize_scalar

        out = np.empty(zeta.shape)
        for idx, z in np.ndenumerate(zeta):
            w0 = 2.0 + float(gamma(2.0, 36.0 * z, z))   # lambda = gamma at the minimum, to leading order
            span = max(20.0 * z, 1e-6)
            res = minimize_scalar(lambda w: float(sigma2(w, z)), bounds=(w0 - span, w0 + span),
                                  method="bounded", options={"xatol": 1e-12})
            out[idx] = res.fun
        return out[()]
    raise ValueError(f"variant must be 'paper', 'sigma1', 'small' or 'min', got {variant!r}")


@_quiet
def region(omega, sigma, zeta, variant="derived"):
    """Region of paper Fig. 3 at each (omega, sigma, zeta): 1, 2 or 3 (``REGION_I/II/III``).

    * I: ``sigma > sigma2`` - the trivial (1T) response is unstable, a subharmonic is always excited.
    * II: ``sigma1 < sigma < sigma2`` on the softening side - 1T stable, coexisting with two
      subharmonics (one stable, one unstable).
    * III: otherwise - no subharmonic.

    variant "derived": decided from the roots of Eq. 23 at the given sigma: I iff
    ``beta**2 sigma**2 > (lambda - gamma)**2 + 4 zeta**2``; II iff not I, ``sigma > sigma1`` and
    ``gamma > lambda`` (both roots positive); the softening side is thus ``lambda < gamma`` (an
    O(zeta**2, B**2) shift from omega = 2).
    variant "paper": the paper's wording, softening side ``omega < 2``, paper gamma.

    Returns
    -------
    region : ndarray of int8
    """
    _check_variant(variant)
    omega = _f(omega)
    sigma = _f(sigma)
    zeta = _f(zeta)
    lam = detuning(omega)
    g = gamma(omega, sigma, zeta, variant)
    b2s2 = beta(omega, zeta) ** 2 * sigma**2
    in_i = b2s2 > (lam - g) ** 2 + 4.0 * zeta**2
    soft = (g > lam) if variant == "derived" else (omega < 2.0)
    in_ii = ~in_i & (b2s2 > 4.0 * zeta**2) & soft
    out = np.full(np.broadcast(omega, sigma, zeta).shape, REGION_III, dtype=np.int8)
    out[in_ii] = REGION_II
    out[in_i] = REGION_I
    return out[()]
