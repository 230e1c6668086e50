# --format json: RunReport in proto3 JSON with the cycle energies at full precision.
set(REGEXES
  "^{\n \"title\": \"Mindlin-Deresiewicz fretting, H1\""
  "\"cycle\": 2,\n *\"dissipated_energy\": 1\\.07238163561[0-9]*e-06"
  "\"records\": \\["
)
