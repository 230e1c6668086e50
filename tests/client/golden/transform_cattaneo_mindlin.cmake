# One Cattaneo-Mindlin term of weight 1: u = mu kappa (g(a) - g(c)) inside the stick zone,
# 0.3 * 17/14 * (3.4829098839e-6 - 2.194e-6) m = 4.695314577e-7 m; the two traction routes agree.
set(REGEXES
  "(^|\n)memory\\[0\\]\\.u +4\\.695314577e-07\n"
  "\nmemory\\[1\\]\\.bound +MEMORY_BOUND_UPPER\n"
  "\ntractions\\[0\\]\\.route +TRACTION_ROUTE_BOTH\n"
)
