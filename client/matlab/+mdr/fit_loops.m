function r = fit_loops(scene, sets, free, varargin)
% mdr.fit_loops  Fits parameters of a single-contact scene to measured loops (the service's
%   FitLoops, in this process): each set's actuator path replayed through the exact engine with
%   the scene's rig, errors in both channels, intervals and an adequacy verdict (docs/analysis.md).
%
%   r = mdr.fit_loops(scene, sets, free, name, value, ...)
%     scene  struct of mdr.v1.Scene: the starting values of the free parameters
%     sets   struct array, one per run: displacement (m), tangential_force (N), normal_force (N:
%            one number, the declared constant load, or one value per sample, replayed as
%            measured), optionally time (s) and declared_normal_force (N, checked against a
%            measured column). A scene with torsion makes the fit torsional: each set has twist
%            (rad) and twisting_moment (N m) instead, replayed through the exact torsional memory
%            at its constant normal force behind the shaft (scene.torsion.rig_compliance)
%     free   struct array: parameter ('friction', 'effective_modulus' (Pa), 'profile_scale' (m),
%            'rig_compliance' (m/N; torsional: rad/(N m)), 'displacement_offset' (m; torsional:
%            rad), 'torsional_modulus' (G_t in Pa, torsional fits)), lower, upper, optionally
%            initial
%   options: 'progress' (@(p) ...: p.iteration, p.residual_rms (N), p.values; return true to
%            stop: then an mdr:cancelled error), 'burn_in_reversals', 'reversal_threshold' (m),
%            'max_iterations', 'nuisances' (struct: force_offset, displacement_drift,
%            moving_mass), 'displacement_noise' (m), 'force_noise' (N), 'include_models'
%
%   r.estimates(k): parameter, value, standard_error, lower_95, upper_95, identified;
%   r.adequate, r.identified, r.sets(k) (noise, reduced_chi_square, misfit, ...), r.nuisances,
%   r.fitted_scene (a torsional fit's torsion.torsional_modulus and rig_compliance), ...
  o = mdr.internal.name_value(struct('progress', [], 'burn_in_reversals', [], 'reversal_threshold', [], ...
                        'max_iterations', [], 'nuisances', [], 'displacement_noise', [], ...
                        'force_noise', [], 'include_models', []), varargin, 'mdr.fit_loops');
  if ~isstruct(sets) || isempty(sets)
    error('mdr:invalidArgument', 'sets: must be a non-empty struct array');
  end
  if ~isstruct(free) || isempty(free)
    error('mdr:invalidArgument', 'free: must be a non-empty struct array');
  end
  request = struct('scene', scene);
  request.sets = arrayfun(@loop_set, sets(:)', 'UniformOutput', false);
  request.free = arrayfun(@free_parameter, free(:)', 'UniformOutput', false);
  for name = {'burn_in_reversals', 'reversal_threshold', 'max_iterations', 'nuisances', ...
              'displacement_noise', 'force_noise', 'include_models'}
    if ~isempty(o.(name{1})), request.(name{1}) = o.(name{1}); end
  end
  r = mdr.internal.run_analysis(2, request, o.progress);
end

function out = loop_set(set)
  samples = mdr.internal.loop_columns(set, struct());
  out = struct();
  if isfield(set, 'normal_force') && isscalar(set.normal_force)
    out.normal_force = set.normal_force;
  elseif isfield(set, 'normal_force') && ~isempty(set.normal_force)
    samples.normal_force = mdr.internal.json_array(set.normal_force);
  end
  if isfield(set, 'declared_normal_force') && ~isempty(set.declared_normal_force)
    out.normal_force = set.declared_normal_force;
  end
  if isfield(set, 'time') && ~isempty(set.time), samples.time = mdr.internal.json_array(set.time); end
  out.samples = samples;
end

function out = free_parameter(p)
  out = p;
  if isfield(p, 'parameter') && ischar(p.parameter) && isempty(strfind(p.parameter, 'FIT_'))
    out.parameter = ['FIT_PARAMETER_' upper(p.parameter)];
  end
end
