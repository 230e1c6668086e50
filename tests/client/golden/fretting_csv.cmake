# --format csv: the step table with the file's outputs, then the cycle energies.
set(REGEXES
  "^step,tangential_displacement,normal_force,tangential_force,dissipated_energy\n1,0,100,0,0\n"
  "\n# Energy dissipated per cycle\ncycle,segment,dissipated_energy,tangential_work\n1,path\\[1\\],[0-9.e-]+,[0-9.e-]+\n2,path\\[1\\],1\\.07238163[56]e-06,1\\.07[123][0-9]*e-06\n"
)
