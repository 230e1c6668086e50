# Flat punch a0 = 1 mm, G = 80 GPa, nu = 0.3, mu = 0.3, delta = 1 um: F_N = 2 E* a0 delta =
# 457.1428571 N; stick with F_x = 2 G* a0 ux, so at ux = mu kappa delta / 2 = 0.1821428571 um
# (step 11) F_x = mu F_N / 2 = 68.57142857 N; gross slip F_x = mu F_N = 137.1428571 N.
set(REGEXES
  "\n +11 +1e-06 +1\\.821428571e-07 +457\\.1428571 +68\\.5714285[67] +0\\.001\n"
  "\n +31 +1e-06 +5\\.464285714e-07 +457\\.1428571 +137\\.1428571 +0\\.001\n"
)
