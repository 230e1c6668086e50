# Oblique loading ux = 0.2 delta from zero: complete stick, F_x/F_N = 0.2/kappa, kappa = 17/14;
# at delta = d(H1) = 3.4829098839e-6 m: F_N = 100 N, F_x = 16.470588235 N, a = 1.8662555784e-4 m.
set(REGEXES
  "\n +20 +3\\.482909884e-06 +6\\.965819768e-07 +(100|99\\.99999999[0-9]*) +16\\.4705882[34] +0\\.000186625557[78]\n"
)
