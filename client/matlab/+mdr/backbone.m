function r = backbone(scene, normal_force, amplitudes, kind)
% mdr.backbone  Secant stiffness and damping ratio of the exact steady loops against amplitude at
%   one normal force (N): the service's Backbone, in this process.
%
%   r = mdr.backbone(scene, FN, amplitudes)           amplitudes: Q* in N, in (0, mu FN]
%   r = mdr.backbone(scene, FN, amplitudes, 'actuator_displacement')   amplitudes in m, > 0
%   r.loops(k): force_amplitude (N), actuator_amplitude (m), dissipated_energy (J),
%   secant_stiffness (N/m), damping_ratio, energy_ratio, ...
%   A scene with torsion gives the torsional backbone: 'force' amplitudes are M* in N m (below the
%   full-slip moment), 'actuator_displacement' ones the twist in rad through the shaft
%   (scene.torsion.rig_compliance); the loops' figures in rad, N m and N m/rad.
  if nargin < 4, kind = 'force'; end
  kinds = struct('force', 'AMPLITUDE_KIND_FORCE', ...
                 'actuator_displacement', 'AMPLITUDE_KIND_ACTUATOR_DISPLACEMENT');
  if ~ischar(kind) || ~isfield(kinds, kind)
    error('mdr:invalidArgument', 'kind: must be ''force'' or ''actuator_displacement''');
  end
  r = mdr.internal.run_analysis(4, struct('scene', scene, 'normal_force', normal_force, ...
                             'kind', kinds.(kind), 'amplitudes', mdr.internal.json_array(amplitudes)));
end
