"""Numbers printed in Perret-Liaudet & Rigaud (the paper's test rig, section 4), SI units.

These are published values, kept with their printed precision so that tests can compare what
hertzmap computes with what the paper prints, at that precision. hertzmap computes everything it
reports itself (study.analytic.rig from E, nu, R, m, N); nothing here feeds a computation except
the rig's inputs (E, NU, R, M, N).
"""

E = 210e9            # Young's modulus, SAE 52100 steel [Pa] (section 4.1)
NU = 0.29            # Poisson ratio [-] (section 4.1)
R = 12.7e-3          # ball radius (25.4 mm diameter) [m] (section 4.1)
M = 7.1              # moving mass [kg] (section 4.1)
N = 69.7             # static load = weight of the moving cylinder [N] (section 4.1)

K_PRINTED = 6.1e9            # Eq. 29a [N m^-3/2], 2 significant digits
Z_S_PRINTED = 5.1e-6         # Eq. 29b [m], 2 significant digits
F0_PRINTED = 271.0           # Eq. 29c [Hz], 3 significant digits
F0_MEASURED = 270.6          # section 4.2 [Hz]
ZETA_MEASURED = 0.005        # section 4.2 [-]
SIGMA_STAR_EXP = 0.20        # section 4.3, experimental threshold [-]

TAYLOR_CONTACT_LOSS_PRINTED = -1.348  # Eq. 12, root of 1 + q + q^2/6 - q^3/54 [-], 4 digits
