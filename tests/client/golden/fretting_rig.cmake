# H1 behind a rig of 2e-8 m/N, cycled by the actuator: at the first peak the actuator is at
# 7.694965814e-7 m, the contact at 4.694965814e-7 m (F_x = 15 N on the virgin curve, the rig
# carrying 2e-8 m/N * 15 N), and cycles 2 and 3 dissipate the contact's own W = 1.0723816356e-6 J
# (docs/reference-values.md, H1 at T* = 15 N): the rig in series changes neither.
set(REGEXES
  "\n +26 +7\\.694965814e-07 +4\\.694965814e-07 +15 +"
  "\n +2 +path\\[1\\] +1\\.07238163[56]e-06 +"
  "\n +3 +path\\[1\\] +1\\.07238163[56]e-06 +"
)
