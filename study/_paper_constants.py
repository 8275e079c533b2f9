"""Numbers printed in Perret-Liaudet & Rigaud (the paper's test rig, section 4), SI units.

Printed values are kept with their printed precision noted, so tests can compare at that precision.
"""

E = 210e9            # Young's modulus, SAE 52100 steel [Pa]
NU = 0.29            # Poisson ratio [-]
R = 12.7e-3          # ball radius (25.4 mm diameter) [m]
M = 7.1              # moving mass [kg]
N = 69.7             # static load = weight of the moving cylinder [N]

K_PRINTED = 6.1e9            # Eq. 29a [N m^-3/2], 2 significant digits
Z_S_PRINTED = 5.1e-6         # Eq. 29b [m], 2 significant digits
F0_PRINTED = 271.0           # Eq. 29c [Hz], 3 significant digits
F0_MEASURED = 270.6          # section 4.2 [Hz]
ZETA_MEASURED = 0.005        # section 4.2 [-]
SIGMA_STAR_EXP = 0.20        # section 4.3, experimental threshold [-]

TAYLOR_CONTACT_LOSS = -1.348  # Eq. 12, root of 1 + q + q^2/6 - q^3/54 [-]
