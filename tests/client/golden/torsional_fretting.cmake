# H1 twisted between +-phi* = 4.8141258757e-3 rad at F_N = 100 N (docs/reference-values.md,
# "Torsion"): the first peak (step 26) is the virgin curve's M = 2.9593735330e-3 N m at c = a/2,
# every cycle after the first dissipates the Hertz loss at c = a/2, 1.08221447558 in the table's
# units, which is W = 1.8173196119e-5 J at H1's scale (G_t a^3 (mu p0 / G_t)^2 / (4/pi)^2); the work of M
# around the loop (trapezoidal rule, 100 steps per cycle) is the same to 1e-3. At +phi* the slip
# annulus r > a/2 carries tau_phi = mu p0 sqrt(1 - r^2/a^2): 329010978.88 Pa at 0.6 a, 246758234.16
# Pa at 0.8 a, 179265701.03 Pa at 0.9 a.
set(REGEXES
  "\n +26 +3\\.482909884e-06 +100 +0\\.0001866255578 +0\\.004814125876 +0\\.002959373533 +"
  "\n +2 +path\\[1\\] +1\\.81731961[0-9]e-05 +1\\.81[67][0-9]*e-05\n +3 +path\\[1\\] +1\\.81731961[0-9]e-05 +1\\.81[67][0-9]*e-05\n"
  "Record \"phi = \\+phi\\*\" after step 326 \\(a = 0\\.0001866255578 m\\)"
  "\n0\\.0001119753347 +329010978\\.[89]"
  "\n0\\.0001493004463 +246758234\\.[12]"
  "\n0\\.0001679630021 +179265701(\\.0)? "
)
