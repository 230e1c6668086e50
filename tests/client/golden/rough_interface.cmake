# The rough steel interface of examples/rough_interface (3000 asperities, seed 2026) through the
# service. No closed form exists for a population: these are the engine's numbers, and the core
# example (mdr_rough_interface, same population) reports the same approach and count at 5 kN. The
# bolt load is reached exactly; cycles 2 and 3 repeat; --histogram-bins 4 bins the 2299 contacts in
# contact: all at slip fraction 0 under the bolt load alone (step 5), and after the first fretting
# step (step 6) the 15 in gross slip and one nearly there fill the last bin.
set(REGEXES
  "\n +5 +7\\.49394673e-07 +0 +5000 +0 +0 +2299 +0 +0\n"
  "\n +2 +path\\[1\\] +2\\.50154786[0-9]e-05 +2\\.50115653[0-9]e-05\n +3 +path\\[1\\] +2\\.50154786[0-9]e-05 +2\\.50115653[0-9]e-05\n"
  "\n +5 +2299 +0 +0 +0\n +6 +2268 +13 +2 +16\n"
)
