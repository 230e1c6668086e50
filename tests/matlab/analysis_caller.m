% The +mdr analysis on the service reference's noisy loops (capi_service_reference analysis):
% prints the figures that it wrote from the service's answers (analysis_reference.txt), compared
% byte for byte: loop figures, the fit's estimates, the backbone.
%   octave-cli analysis_caller.m PACKAGE_DIR REFERENCE_DIR
arguments = argv();
addpath(arguments{1});
reference_dir = arguments{2};
scene = jsondecode(fileread(fullfile(reference_dir, 'analysis_scene.json')));
lines = strsplit(strtrim(fileread(fullfile(reference_dir, 'analysis_samples.txt'))), "\n");
u = zeros(1, numel(lines));
fx = zeros(1, numel(lines));
for i = 1:numel(lines)
  f = strsplit(lines{i});
  u(i) = hex2num(f{1});
  fx(i) = hex2num(f{2});
end

function h = hexd(values)
  h = strjoin(arrayfun(@(v) upper(num2hex(v)), values, 'UniformOutput', false), ' ');
end

loops = mdr.analyze_loops(u, fx, 'normal_force', 100, 'scene', scene);
for k = 1:numel(loops.cycles)
  c = loops.cycles(k);
  printf('C %s %s\n', hexd([c.force_amplitude, c.dissipated_energy, c.half_opening, ...
                            c.energy_ratio, c.sliding_ratio, c.secant_stiffness]), c.regime);
end
iterations = 0;
fit = mdr.fit_loops(scene, struct('displacement', u, 'tangential_force', fx, 'normal_force', 100), ...
                    struct('parameter', 'friction', 'initial', 0.25, 'lower', 0.05, 'upper', 0.9), ...
                    'progress', @(p) false);
for k = 1:numel(fit.estimates)
  e = fit.estimates(k);
  verdict = 'not_identified';
  if e.identified, verdict = 'identified'; end
  printf('E %s %s\n', hexd([e.value, e.standard_error, e.lower_95, e.upper_95]), verdict);
end
backbone = mdr.backbone(scene, 100, [5 15 25]);
for k = 1:numel(backbone.loops)
  printf('B %s\n', hexd([backbone.loops(k).secant_stiffness, backbone.loops(k).damping_ratio]));
end
