# Steel on aluminium, R = 5 mm, mu = 0.2, F_N = 50 N: E* = 58.6051963 GPa, kappa = 1.23814640;
# a = (3 F_N R / (4 E*))^(1/3) = 1.473516655e-4 m, d = a^2/R = 4.342502664e-6 m; at F_x = 5 N
# (s = 0.5) u0 = mu kappa d (1 - 0.5^(2/3)) = 3.979148482e-7 m; the second (steady) cycle of
# amplitude 5 N dissipates W = 3.029603712e-7 J (docs/reference-values.md, formula for n = 2),
# and the work of F_x around it is the same to 3e-3 (trapezoidal rule, 40 steps per cycle).
set(REGEXES
  "\n +11 +4\\.342502664e-06 +3\\.979148482e-07 +50 +5 +0\\.0001473516655\n"
  "\n +2 +path\\[4\\] +3\\.02960371[12]e-07 +3\\.0[12][0-9]*e-07\n"
)
