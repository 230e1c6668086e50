function r = analyze_loops(varargin)
% mdr.analyze_loops  The figures of every complete cycle of a measured run (the service's
%   AnalyzeLoops, in this process). SI units.
%
%   r = mdr.analyze_loops(u, Fx)        u: displacement (m), Fx: tangential force (N), one value
%                                       per sample
%   r = mdr.analyze_loops(record)       a struct of the columns: displacement and
%                                       tangential_force, or a torsional record (a ball twisted on
%                                       a flat) with twist (rad) and twisting_moment (N m)
%   r = mdr.analyze_loops(..., name, value, ...) with
%     'normal_force'  N: one value per sample (measured), or one number (a constant load)
%     'time'          s: one value per sample, strictly increasing
%     'scene'         struct of mdr.v1.Scene: classifies each cycle against the real profile's
%                     onset of gross slip at the cycle's normal force; a torsional record's scene
%                     has torsion (e.g. torsion = struct('rig_compliance', 0.5)) and classifies
%                     against its full-slip moment
%     'options'       struct of LoopAnalysisOptions: reversal_threshold (m; torsional: rad),
%                     rig_compliance (m/N; torsional: the shaft's, rad/(N m)),
%                     displacement_resolution (m; rad), closure_tolerance, ...
%
%   r.cycles(k): first_sample, last_sample (0-based), force_amplitude Q* (N), dissipated_energy
%   Ed (J), half_opening (m), displacement_amplitude (m), energy_ratio A, sliding_ratio B,
%   system_free_ratio C, friction_coefficient, regime ('REGIME_PARTIAL_SLIP', ...), flags, ...;
%   r.reversals (0-based sample indices), r.friction_drift. A torsional record's figures keep
%   their definitions in rad and N m (force_amplitude M* in N m, half_opening in rad, stiffnesses
%   in N m/rad), its friction_coefficient is NaN, and with a scene full_slip_moment (N m) is the
%   scene's at each cycle's load. docs/analysis.md defines each figure.
%   Errors (mdr:invalidArgument, ...) name the field: 'samples.tangential_force',
%   'samples.twist' (a record of both pairs), 'scene.torsion' (a scene of the other kind), ...
  if nargin >= 1 && isstruct(varargin{1})
    record = varargin{1};
    known = {'displacement', 'tangential_force', 'twist', 'twisting_moment'};
    unknown = setdiff(fieldnames(record)', known);
    if ~isempty(unknown)
      error('mdr:invalidArgument', 'record.%s: unknown field (a record has %s)', unknown{1}, ...
            strjoin(known, ', '));
    end
    samples = mdr.internal.loop_columns(record, struct());
    rest = varargin(2:end);
  elseif nargin >= 2
    samples = struct('displacement', mdr.internal.json_array(varargin{1}), ...
                     'tangential_force', mdr.internal.json_array(varargin{2}));
    rest = varargin(3:end);
  else
    error('mdr:invalidArgument', ['mdr.analyze_loops: give the displacement and the tangential ' ...
                                  'force, or a record struct (twist and twisting_moment)']);
  end
  o = mdr.internal.name_value(struct('normal_force', [], 'time', [], 'scene', [], 'options', struct()), ...
                 rest, 'mdr.analyze_loops');
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
