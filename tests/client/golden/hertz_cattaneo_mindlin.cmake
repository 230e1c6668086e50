# H1 by force control (README quick start): F_N = 100 N, then F_x = 15 N gives
# u0 = 4.6949658143e-7 m at d = 3.4829098839e-6 m and a = 1.8662555784e-4 m.
set(REGEXES
  "\n +4 +3\\.482909884e-06 +4\\.694965814e-07 +100 +15 +0\\.0001866255578"
)
