% The +mdr analysis of a torsional record (a ball twisted on a flat behind a shaft, with seeded
% noise, from capi_service_reference analysis): prints the figures that the service wrote from its
% own answers (torsion_analysis_reference.txt), compared byte for byte: the loop figures and the
% full-slip moment, a fit of mu and G_t, the backbone by the actuator's twist.
%   octave-cli torsion_analysis_caller.m PACKAGE_DIR REFERENCE_DIR
arguments = argv();
addpath(arguments{1});
reference_dir = arguments{2};
scene = jsondecode(fileread(fullfile(reference_dir, 'torsion_analysis_scene.json')));
lines = strsplit(strtrim(fileread(fullfile(reference_dir, 'torsion_analysis_samples.txt'))), "\n");
phi = zeros(1, numel(lines));
moment = zeros(1, numel(lines));
for i = 1:numel(lines)
  f = strsplit(lines{i});
  phi(i) = hex2num(f{1});
  moment(i) = hex2num(f{2});
end

function h = hexd(values)
  h = strjoin(arrayfun(@(v) upper(num2hex(v)), values, 'UniformOutput', false), ' ');
end

record = struct('twist', phi, 'twisting_moment', moment);
loops = mdr.analyze_loops(record, 'normal_force', 100, 'scene', scene, ...
                          'options', struct('rig_compliance', 0.5));
for k = 1:numel(loops.cycles)
  c = loops.cycles(k);
  printf('C %s %s %s\n', hexd([c.force_amplitude, c.dissipated_energy, c.half_opening, ...
                               c.energy_ratio, c.sliding_ratio, c.secant_stiffness]), c.regime, ...
         hexd(c.full_slip_moment));
end
start = scene;
start.friction = 0.25;
free = struct('parameter', {'friction', 'torsional_modulus'}, 'initial', {0.25, 3e10}, ...
              'lower', {0.05, 1e9}, 'upper', {0.9, 1e12});
fit = mdr.fit_loops(start, struct('twist', phi, 'twisting_moment', moment, 'normal_force', 100), ...
                    free);
for k = 1:numel(fit.estimates)
  e = fit.estimates(k);
  verdict = 'not_identified';
  if e.identified, verdict = 'identified'; end
  printf('E %s %s\n', hexd([e.value, e.standard_error, e.lower_95, e.upper_95]), verdict);
end
backbone = mdr.backbone(scene, 100, [1e-4 2e-3 6e-3], 'actuator_displacement');
for k = 1:numel(backbone.loops)
  printf('B %s\n', hexd([backbone.loops(k).secant_stiffness, backbone.loops(k).damping_ratio]));
end
