# Samples of the H1 sphere: the H1 numbers (d = 3.4829098839e-6 m, u0 = 4.6949658143e-7 m,
# a = 1.8662555784e-4 m) to about 5 digits; the interpolation between samples is not the exact
# parabola (3.4829176e-6 m here: 2e-6 relative).
set(REGEXES
  "\n +4 +3\\.48291[0-9]*e-06 +4\\.6949[0-9]*e-07 +100 +15 +0\\.0001866[23][0-9]*\n"
  "Record \"F_x = 15 N\" after step 4"
)
