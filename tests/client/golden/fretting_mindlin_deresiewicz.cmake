# H1 at T* = 15 N (s = 0.5): every cycle after the first dissipates W = 1.0723816356e-6 J
# (docs/reference-values.md), and the work of F_x around the loop (trapezoidal rule, 100 steps per
# cycle) is the same to 1e-3; the turning points are F_x = +-15 N at F_N = 100 N and
# u0 = 4.6949658143e-7 m on the virgin curve (step 26, the first peak).
set(REGEXES
  "\n +2 +path\\[1\\] +1\\.07238163[56]e-06 +1\\.07[123][0-9]*e-06\n +3 +path\\[1\\] +1\\.07238163[56]e-06 +1\\.07[123][0-9]*e-06\n"
  "\n +26 +4\\.694965814e-07 +100 +15 +"
  "\n +376 +-?[0-9.e-]+ +100 +-15 +"
  "Record \"F_x = \\+15 N\" after step 326 \\(a = 0\\.0001866255578 m\\)"
)
