function r = fretting_map(scene, normal_forces, relative_amplitudes)
% mdr.fretting_map  The exact steady loops of a single-contact scene (with its rig) on a grid of
%   normal forces (N, each > 0, 1 to 100) and actuator amplitudes relative to the onset of gross
%   slip at each force (each in (0, 100], 1 to 200): the service's FrettingMap, in this process.
%
%   r.loads(i).onset: the figures at the onset (force_amplitude N, actuator_amplitude m, ...);
%   r.loads(i).loops(j): each loop's figures (dissipated_energy J, energy_ratio, damping_ratio, ...);
%   r.loads(i).regimes{j} or (j): 'REGIME_STICKING', 'REGIME_PARTIAL_SLIP' or 'REGIME_GROSS_SLIP'.
  r = mdr.internal.run_analysis(3, struct('scene', scene, 'normal_forces', mdr.internal.json_array(normal_forces), ...
                             'relative_amplitudes', mdr.internal.json_array(relative_amplitudes)));
end
