"""The dimensionless equation of motion (paper Eq. 7, generalised to a contact law k z^n).

    q'' + 2 zeta q' + F(q) = 1 + sigma cos(omega tau)

* ``HERTZ`` (paper Eq. 7 for n = 3/2): F(q) = (1 + q/n)^n for q >= -n, 0 below (loss of contact).
  With z = z_s (1 + q/n) the law k z^n gives this form for any n > 0 (n = 1: linear impact
  oscillator, n = 10/9: line contact). Contact is lost at q = -n.
* ``TAYLOR`` (paper Eq. 10-11): F(q) = 1 + q + q^2/6 - q^3/54, the third-order expansion of the
  n = 3/2 law about the static load; it never loses contact (valid for q >= TAYLOR_CONTACT_LOSS = 6 - 3 sqrt(6), Eq. 12).

All quantities are dimensionless: q displacement (Eq. 5), tau = Omega t (Eq. 6), omega the
excitation frequency over Omega (Eq. 8), sigma the force amplitude over the static load N,
zeta the damping ratio (Eq. 4). F is the contact force over N.

F is continuous at q = -n (F(-n) = 0), so the vector field is continuous across the switching
surface and the saltation matrix of a contact loss or recontact is the identity.
"""
from dataclasses import dataclass
from math import cos, isfinite, nan, sqrt

from numba import float64, int64
from numba.types import UniTuple

from hertzmap.kernels._jit import kernel

HERTZ = 0
TAYLOR = 1

#: The model every solve takes unless told otherwise, declared once: the Hertz law (paper
#: Eq. 7) with n = 3/2, and the shooting's integrator tolerance (relative and absolute, on
#: (q, q') and the monodromy matrix). Function signatures name these instead of restating them.
DEFAULT_LAW = "hertz"
DEFAULT_EXPONENT = 1.5
DEFAULT_RTOL = 1e-10

#: Paper Eq. 12: the Taylor force 1 + q + q^2/6 - q^3/54 of Eq. 10 vanishes here, the Taylor
#: model's "loss of contact". The cubic factors exactly, -54 F = (q + 3)(q^2 - 12 q - 18), so
#: its roots are -3 and 6 -+ 3 sqrt(6); the first one met going down from the static point is
#: 6 - 3 sqrt(6) = -1.3484692... (the paper prints it to four digits, study.analytic.paper).
#: Every threshold of the Taylor model is this one.
TAYLOR_CONTACT_LOSS = 6.0 - 3.0 * sqrt(6.0)


@dataclass(frozen=True)
class ContactLaw:
    """A contact law F(q), declared once; the kernels' force functions below branch on its
    ``code``, the integrator on ``switches`` (a switching surface at the loss level, below
    which F = 0 and the flight is integrated in closed form), the study file on ``name`` and
    ``has_exponent``. The loss level, the q at which contact is lost (the integrator's
    switching surface and the grazing threshold of every product), is declared as
    ``loss_slope * n + loss_offset`` (n the contact exponent): the kernels read it through
    LOSS_SLOPE and LOSS_OFFSET (``switch_level``), Python through ``loss_level(n)``. Its
    independent twin for the tests is benchmarks/oracle.py's ``force`` of the same name."""

    name: str
    code: int
    switches: bool
    has_exponent: bool
    loss_slope: float
    loss_offset: float
    equation: str
    description: str

    def loss_level(self, n) -> float:
        """q at which contact is lost for the exponent n: loss_slope * n + loss_offset, the
        same arithmetic as the kernels' ``switch_level`` (a law whose level does not depend on
        n takes any n, None included)."""
        if self.loss_slope == 0.0:
            return float(self.loss_offset)
        return float(self.loss_slope) * float(n) + float(self.loss_offset)


LAWS = (
    # level -n: -1.0 * n + 0.0 is -n exactly (IEEE), so the integrator's q - level is q + n
    ContactLaw("hertz", HERTZ, True, True, -1.0, 0.0, "Eq. 7",
               "F = (1 + q/n)^n in contact, 0 in flight below q = -n (n = 3/2: Hertz)"),
    ContactLaw("taylor", TAYLOR, False, False, 0.0, TAYLOR_CONTACT_LOSS, "Eq. 10-12",
               "F = 1 + q + q^2/6 - q^3/54, the third-order expansion of the n = 3/2 law; "
               "never loses contact (valid above TAYLOR_CONTACT_LOSS)"),
)
#: name -> code of every law
MODELS = {law.name: law.code for law in LAWS}
#: code -> law
LAW_OF_CODE = {law.code: law for law in LAWS}
#: code -> has a switching surface (a compile-time constant of the integrator)
SWITCHES = tuple(LAW_OF_CODE[c].switches for c in range(len(LAWS)))
#: code -> the loss level's slope and offset, level = LOSS_SLOPE * n + LOSS_OFFSET (the
#: integrator's switching surface: ``switch_level``)
LOSS_SLOPE = tuple(float(LAW_OF_CODE[c].loss_slope) for c in range(len(LAWS)))
LOSS_OFFSET = tuple(float(LAW_OF_CODE[c].loss_offset) for c in range(len(LAWS)))
#: code -> the contact-loss level of a law whose level does not depend on the exponent (NaN
#: for the others, whose level, -n for the Hertz law, does)
FIXED_LOSS_LEVEL = tuple(LOSS_OFFSET[c] if LOSS_SLOPE[c] == 0.0 else nan
                         for c in range(len(LAWS)))


def contact_loss_level(model: str, exponent: float) -> float:
    """q at which contact is lost: -n for the Hertz law (paper Eq. 7), TAYLOR_CONTACT_LOSS for
    the Taylor model (Eq. 11-12). Dimensionless."""
    return LAW_OF_CODE[MODELS[model]].loss_level(exponent)


def model_code(model: str) -> int:
    """The kernels' int code of a contact law by name (a ValueError naming the laws otherwise)."""
    try:
        return MODELS[model]
    except KeyError:
        raise ValueError(f"model must be one of {sorted(MODELS)}, got {model!r}") from None


def check_exponent(exponent: float) -> float:
    """The contact exponent n as a float, or a ValueError unless finite and > 0."""
    exponent = float(exponent)
    if not (isfinite(exponent) and exponent > 0.0):    # math's: numpy's costs 1 us a call
        raise ValueError(f"exponent must be a finite number > 0, got {exponent!r}")
    return exponent


@kernel(float64(float64, int64))
def switch_level(n, model):
    """The law's contact-loss level for the exponent n, as declared (LAWS): the q of the
    integrator's switching surface (-1.0 * n + 0.0 = -n exactly for the Hertz law)."""
    return LOSS_SLOPE[model] * n + LOSS_OFFSET[model]


@kernel(float64(float64, float64, int64))
def rhs_force(q, n, model):
    """Contact force F(q) / N (dimensionless)."""
    if model == TAYLOR:
        return 1.0 + q + q * q / 6.0 - q * q * q / 54.0
    s = 1.0 + q / n
    if s <= 0.0:
        return 0.0
    if n == 1.5:
        return s * sqrt(s)
    if n == 1.0:
        return s
    return s ** n


@kernel(UniTuple(float64, 2)(float64, float64, int64))
def rhs_force_and_stiffness(q, n, model):
    """F(q) and its derivative F'(q) (the contact stiffness, 1 at the static point)."""
    if model == TAYLOR:
        return 1.0 + q + q * q / 6.0 - q * q * q / 54.0, 1.0 + q / 3.0 - q * q / 18.0
    s = 1.0 + q / n
    if s <= 0.0:
        return 0.0, 0.0
    if n == 1.5:
        r = sqrt(s)
        return s * r, r
    if n == 1.0:
        return s, 1.0
    p = s ** (n - 1.0)
    return p * s, p


@kernel(float64(float64, float64, int64))
def contact_side_force(q, n, model):
    """F(q) continued past q = -n as the odd extension sign(s) |s|^n, s = 1 + q/n.

    Used only by the integrator's stages inside a contact step: a step that lands exactly on
    the switch has stages a round-off beyond it, where the clamped law would make F'(q) jump
    (n = 1) and the error estimate of the variational equations explode. The odd extension is
    exactly linear for n = 1 and C^1 for n > 1. Flight itself is integrated in closed form.
    """
    if model == TAYLOR:
        return 1.0 + q + q * q / 6.0 - q * q * q / 54.0
    s = 1.0 + q / n
    if n == 1.0:
        return s
    a = abs(s)
    if n == 1.5:
        f = a * sqrt(a)
    else:
        f = a ** n
    return f if s >= 0.0 else -f


@kernel(UniTuple(float64, 2)(float64, float64, int64))
def contact_side_force_and_stiffness(q, n, model):
    """contact_side_force and its derivative |s|^(n-1)."""
    if model == TAYLOR:
        return 1.0 + q + q * q / 6.0 - q * q * q / 54.0, 1.0 + q / 3.0 - q * q / 18.0
    s = 1.0 + q / n
    if n == 1.0:
        return s, 1.0
    a = abs(s)
    if n == 1.5:
        r = sqrt(a)
        return (a * r if s >= 0.0 else -a * r), r
    p = a ** (n - 1.0)
    return (p * a if s >= 0.0 else -p * a), p


@kernel(float64(float64, float64, float64, float64))
def cos_shifted(c0, s0, phi0, theta):
    """cos(phi0 + theta) from c0 = cos(phi0) and s0 = sin(phi0) (the excitation of Eq. 7 at
    the stages of one integration step, phi0 = omega t at the step start).

    For |theta| <= 1, cos(theta) and sin(theta) by their Taylor series to theta^18 and
    theta^17 (truncation below 1e-17): a dozen independent multiply-adds instead of a libm
    cosine, 12 per step (a step became 1.10-1.13x faster). Else libm's cos(phi0 + theta).
    """
    if abs(theta) <= 1.0:
        t2 = theta * theta
        # Horner in theta^2; coefficients (-1)^j / (2j)! and (-1)^j / (2j+1)!
        c = 1.0 + t2 * (-1.0 / 2.0 + t2 * (1.0 / 24.0 + t2 * (-1.0 / 720.0 + t2 * (
            1.0 / 40320.0 + t2 * (-1.0 / 3628800.0 + t2 * (1.0 / 479001600.0 + t2 * (
                -1.0 / 87178291200.0 + t2 * (1.0 / 20922789888000.0 + t2 * (
                    -1.0 / 6402373705728000.0)))))))))
        s = theta * (1.0 + t2 * (-1.0 / 6.0 + t2 * (1.0 / 120.0 + t2 * (-1.0 / 5040.0 + t2 * (
            1.0 / 362880.0 + t2 * (-1.0 / 39916800.0 + t2 * (1.0 / 6227020800.0 + t2 * (
                -1.0 / 1307674368000.0 + t2 * (1.0 / 355687428096000.0)))))))))
        return c0 * c - s0 * s
    return cos(phi0 + theta)


def contact_force(q, exponent=DEFAULT_EXPONENT, model=DEFAULT_LAW):
    """Vectorised F(q) for numpy arrays (post-processing; not used inside the kernels)."""
    import numpy as np

    q = np.asarray(q, dtype=float)
    if MODELS[model] == TAYLOR:
        return 1.0 + q + q**2 / 6.0 - q**3 / 54.0
    s = np.maximum(1.0 + q / exponent, 0.0)
    return s**exponent


@dataclass(frozen=True)
class Model:
    """A contact law with its exponent, and the integrator's tolerance: the value a solve is
    given (the study's [model] and [solver] tables, a store's attrs, a solver's options dict).
    ``exponent`` is n of the law F = (1 + q/n)^n (ignored by a law without one); ``rtol`` the
    shooting's relative tolerance (dimensionless)."""

    law: str = DEFAULT_LAW
    exponent: float = DEFAULT_EXPONENT
    rtol: float = DEFAULT_RTOL

    def __post_init__(self):
        model_code(self.law)
        object.__setattr__(self, "exponent", check_exponent(self.exponent))
        object.__setattr__(self, "rtol", float(self.rtol))

    @property
    def code(self) -> int:
        """The kernels' int code of the law."""
        return MODELS[self.law]

    @property
    def loss_level(self) -> float:
        """q at which contact is lost (the law's declaration, LAWS)."""
        return contact_loss_level(self.law, self.exponent)

    @classmethod
    def of(cls, options) -> "Model":
        """The model of a solver options dict or a store's attrs (keys ``model``, ``exponent``,
        ``rtol``; a missing or None one takes the default)."""
        values = {"law": options.get("model"), "exponent": options.get("exponent"),
                  "rtol": options.get("rtol")}
        try:
            # a law without an exponent: a store's attrs may hold "none" there
            float(values["exponent"])
        except (TypeError, ValueError):
            values["exponent"] = None
        return cls(**{k: v for k, v in values.items() if v is not None})
