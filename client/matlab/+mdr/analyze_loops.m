function r = analyze_loops(displacement, tangential_force, varargin)
% mdr.analyze_loops  The figures of every complete cycle of a measured run (the service's
%   AnalyzeLoops, in this process). SI units.
%
%   r = mdr.analyze_loops(u, Fx)        u: displacement (m), Fx: tangential force (N), one value
%                                       per sample
%   r = mdr.analyze_loops(u, Fx, name, value, ...) with
%     'normal_force'  N: one value per sample (measured), or one number (a constant load)
%     'time'          s: one value per sample, strictly increasing
%     'scene'         struct of mdr.v1.Scene: classifies each cycle against the real profile's
%                     onset of gross slip at the cycle's normal force
%     'options'       struct of LoopAnalysisOptions: reversal_threshold (m), rig_compliance
%                     (m/N), displacement_resolution (m), closure_tolerance, ...
%
%   r.cycles(k): first_sample, last_sample (0-based), force_amplitude Q* (N), dissipated_energy
%   Ed (J), half_opening (m), displacement_amplitude (m), energy_ratio A, sliding_ratio B,
%   system_free_ratio C, friction_coefficient, regime ('REGIME_PARTIAL_SLIP', ...), flags, ...;
%   r.reversals (0-based sample indices), r.friction_drift. docs/analysis.md defines each figure.
%   Errors (mdr:invalidArgument, ...) name the field: 'samples.tangential_force', ...
  o = mdr.internal.name_value(struct('normal_force', [], 'time', [], 'scene', [], 'options', struct()), ...
                 varargin, 'mdr.analyze_loops');
  samples = struct('displacement', mdr.internal.json_array(displacement), ...
                   'tangential_force', mdr.internal.json_array(tangential_force));
  options = o.options;
  if isscalar(o.normal_force)
    options.normal_force = o.normal_force;
  elseif ~isempty(o.normal_force)
    samples.normal_force = mdr.internal.json_array(o.normal_force);
  end
  if ~isempty(o.time), samples.time = mdr.internal.json_array(o.time); end
  request = struct('samples', samples, 'options', options);
  if ~isempty(o.scene), request.scene = o.scene; end
  r = mdr.internal.run_analysis(1, request);
end
