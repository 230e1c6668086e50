# Three H1 contacts as a contact list (run with --contact-index 0): pressed to d = 3.4829098839e-6 m
# each carries F_N = 100 N (docs/reference-values.md, H1), 300 N in all; two fret with u0 =
# 4.6949658143e-7 m, so at the first peak (step 4 + 25) each carries F_x = 15 N, 30 N in all, two
# in partial slip and the holding one sticking; every steady cycle dissipates 2 W(H1) =
# 2.1447632712e-6 J; a list's ux is 0, so its work of F_x is 0. Contact 0 alone is H1's state.
set(REGEXES
  "\n +4 +300 +0 +0 +3 +0 +0\n"
  "\n +29 +300 +(30|29\\.99999999[0-9]*|30\\.00000000[0-9]*) +[0-9.e-]+ +3 +2 +0\n"
  "\n +2 +path\\[1\\] +2\\.14476327[01]e-06 +0\n +3 +path\\[1\\] +2\\.14476327[01]e-06 +0\n"
  "\nContact 0\n"
  "\n +29 +3\\.482909884e-06 +4\\.694965814e-07 +100 +15 +0\\.0001866255578 +[0-9.e-]+\n"
)
