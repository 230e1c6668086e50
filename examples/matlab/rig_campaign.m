% A rig engineer's first script with the +mdr package (MATLAB or Octave): the fretting campaign
% of examples/rig_campaign (a steel sphere on a steel flat behind a compliant rig, 3 loads x 3
% amplitudes, synthetic data with sensor noise), read from its CSV files; mu, E* and the rig's
% compliance fitted to all runs at once; each run's loops analysed against the fitted contact;
% then its backbone and fretting map. SI units throughout: m, N, Pa, s.
%
%   addpath('build/release/client/matlab/mdr')      % the built package (docs/matlab.md)
%   run('examples/matlab/rig_campaign.m')
% or, from the repository root:  octave-cli examples/matlab/rig_campaign.m
here = fileparts(mfilename('fullpath'));
if exist('mdr_mex', 'file') ~= 3
  addpath(fullfile(here, '..', '..', 'build', 'release', 'client', 'matlab', 'mdr'));
end
data_dir = fullfile(here, '..', 'rig_campaign', 'data');

% The starting scene: what the lab believes before the fit (the fit's initial values).
steel = struct('youngs_modulus_1', 163.8e9, 'poisson_ratio_1', 0.3, ...
               'youngs_modulus_2', 163.8e9, 'poisson_ratio_2', 0.3);
scene = struct('sphere', struct('radius', 0.01), 'elastic_pair', steel, 'friction', 0.45, ...
               'rig', struct('tangential_compliance', 3e-8));

% The runs: p<normal force>N_u<amplitude>um.csv with columns time, displacement,
% tangential_force after three comment lines and a header.
loads = [50 100 200];
amplitudes = {'1.5', '4', '8'};
sets = struct('displacement', {}, 'tangential_force', {}, 'normal_force', {}, 'time', {});
names = {};
for load = loads
  for k = 1:numel(amplitudes)
    names{end + 1} = sprintf('p%dN_u%sum.csv', load, amplitudes{k});  %#ok<AGROW>
    columns = dlmread(fullfile(data_dir, names{end}), ',', 4, 0);
    sets(end + 1) = struct('displacement', columns(:, 2)', 'tangential_force', columns(:, 3)', ...
                           'normal_force', load, 'time', columns(:, 1)');  %#ok<AGROW>
  end
end

% mu, E* and the rig's compliance from all nine runs, with 95 % intervals and a verdict.
free = struct('parameter', {'friction', 'effective_modulus', 'rig_compliance'}, ...
              'initial', {0.45, 9e10, 3e-8}, 'lower', {0.05, 1e10, 1e-10}, ...
              'upper', {1.5, 1e12, 1e-6});
printf('\nfitting %d runs:', numel(sets));
fit = mdr.fit_loops(scene, sets, free, 'max_iterations', 100, ...
                    'progress', @(p) fprintf(' %d', p.iteration) < 0);
printf('\n%-20s %14s %14s %14s  %s\n', 'parameter', 'value', 'lower 95 %', 'upper 95 %', '');
for e = fit.estimates(:)'
  verdict = 'identified';
  if ~e.identified, verdict = 'NOT identified'; end
  printf('%-20s %14.6g %14.6g %14.6g  %s\n', strrep(e.parameter, 'FIT_PARAMETER_', ''), ...
         e.value, e.lower_95, e.upper_95, verdict);
end
if fit.adequate
  printf('the model explains every run to its noise\n');
else
  printf('the model does NOT explain every run: see fit.sets(k).misfit\n');
end

% The fitted scene: E* = E / (2 (1 - nu^2)) for two bodies of the same steel.
fitted = scene;
fitted.friction = fit.estimates(1).value;
youngs = 2 * (1 - 0.3^2) * fit.estimates(2).value;
fitted.elastic_pair.youngs_modulus_1 = youngs;
fitted.elastic_pair.youngs_modulus_2 = youngs;
fitted.rig.tangential_compliance = fit.estimates(3).value;

% Each run's last cycle, classified against the fitted contact's onset of gross slip. The label
% compares the loop's C = Ed / (4 delta_0 Q*) with the onset's (docs/analysis.md): where the half
% opening delta_0 is within a few noise levels (the 1.5 um runs at 200 N: 19 nm against 10 nm of
% noise), C scatters and a near-sticking loop can be labelled gross slip; the option
% displacement_resolution (a few times the sensor's noise) calls such loops sticking instead.
printf('\n%-18s %8s %10s %9s %7s  %s\n', 'run', 'Q* (N)', 'Ed (uJ)', 'd0 (um)', 'A', 'regime');
for k = 1:numel(sets)
  loops = mdr.analyze_loops(sets(k).displacement, sets(k).tangential_force, ...
                            'normal_force', sets(k).normal_force, 'time', sets(k).time, ...
                            'scene', fitted);
  last = loops.cycles(end);
  printf('%-18s %8.2f %10.3f %9.3f %7.3f  %s\n', names{k}, last.force_amplitude, ...
         1e6 * last.dissipated_energy, 1e6 * last.half_opening, last.energy_ratio, ...
         strrep(last.regime, 'REGIME_', ''));
end

% The fitted contact's backbone at 100 N and its fretting map.
backbone = mdr.backbone(fitted, 100, linspace(2, 0.95 * fitted.friction * 100, 8));
printf('\nbackbone at 100 N:  Q* (N)  secant stiffness (N/um)  damping ratio\n');
for l = backbone.loops(:)'
  printf('                    %6.2f  %22.2f  %13.4f\n', l.force_amplitude, ...
         1e-6 * l.secant_stiffness, l.damping_ratio);
end
map = mdr.fretting_map(fitted, loads, [0.5 0.9 1.1 2]);
printf('\nfretting map (relative amplitude 0.5, 0.9, 1.1, 2):\n');
for i = 1:numel(loads)
  printf('  %3d N: %s\n', loads(i), strjoin(strrep(map.loads(i).regimes', 'REGIME_', ''), ', '));
end

% A contact of the fitted scene, stepped like the rig: the state after a partial-slip cycle.
c = mdr.Contact(fitted);
c.step('normal_force', 100);
for u = 1.5e-6 * sin(2 * pi * (1:64) / 64)
  c.step('displacement', u);
end
s = c.state();
printf('\nafter one 1.5 um cycle at 100 N: F_x = %.3f N, dissipated %.3f uJ, %d memory vertices\n', ...
       s.tangential_force, 1e6 * s.dissipated_energy, s.memory_vertices);
