# F_N cycling 70 <-> 130 N at fixed ux after F_x = 15 N: the first cycle dissipates (the edge
# slips while the contact shrinks), then the contact shakes down: later cycles dissipate nothing
# (below 1e-20 J of round-off). ux and F_x at F_N = 100 N again after each cycle. ux is held, so
# the work of F_x (the last column) is 0.
set(REGEXES
  "\n +1 +path\\[2\\] +[1-9][0-9.]*e-07 +0\n"
  "\n +2 +path\\[2\\] +(0|-?[0-9.]+e-(2[0-9]|[3-9][0-9])) +0\n +3 +path\\[2\\] +(0|-?[0-9.]+e-(2[0-9]|[3-9][0-9])) +0\n"
)
