classdef Contact < handle
% mdr.Contact  One exact tangential contact in this process (libmdr_c, no server). SI units.
%
%   c = mdr.Contact(scene)       scene: a struct of mdr.v1.Scene's fields, e.g.
%                                struct('sphere', struct('radius', 0.01), 'friction', 0.3,
%                                       'elastic_pair', struct('youngs_modulus_1', 210e9, ...))
%                                or the name of a YAML or JSON scene file (as mdrctl reads it)
%   c = mdr.Contact.restore(b)   from a SessionSnapshot (uint8), e.g. the service's ExportSession
%
%   r = c.step(name, value, ...) one step, atomic (on an error nothing changed). Channels:
%       normal:     'depth' (m), 'depth_increment' (m), 'normal_force' (N)
%       tangential: 'displacement' (m), 'displacement_increment' (m), 'tangential_force' (N)
%       at most one of each; an omitted channel holds. Also c.step(struct('normal_force', 100)).
%       r: substeps, path_error (relative), dissipated (J).
%   s = c.state()                depth, tangential_displacement, contact_radius (m),
%                                normal_force, tangential_force, friction_limit (N),
%                                dissipated_energy, last_step_dissipation (J), actuator_*,
%                                applied_steps, memory_vertices
%   [kp, kn] = c.stiffness()     dF_x/du_x for a further move in +x and in -x (N/m)
%   I = c.slip_intervals()       n-by-3: r_begin (m), r_end (m), direction (+1 or -1)
%   [W, edge] = c.jager_weights() n-by-3: r_begin (m), r_end (m), weight; the punch edge's weight
%   T = c.tractions(radii, route) n-by-4 at radii (m): tau, tau_error, p, p_error (Pa);
%                                route 'both' (default), 'abel' or 'jager'
%   b = c.snapshot()             uint8 SessionSnapshot; ImportSession and restore continue it
%                                bit for bit
%
% Errors are MATLAB errors with identifiers mdr:invalidArgument, mdr:failedPrecondition,
% mdr:resourceExhausted, ...; the message names the argument or the scene field and its range.
% The contact is released when the object is cleared.

  properties (Access = private)
    handle
  end

  methods
    function obj = Contact(scene, handle)
      if nargin == 2 && isequal(scene, 'restored')  % from Contact.restore
        obj.handle = handle;
        return
      end
      if nargin ~= 1
        error('mdr:invalidArgument', 'usage: mdr.Contact(scene) with a struct or a file name');
      end
      [text, name] = mdr.internal.scene_text(scene);
      obj.handle = mdr_mex('create', text, name);
    end

    function delete(obj)
      if ~isempty(obj.handle)
        mdr_mex('destroy', obj.handle);
        obj.handle = [];
      end
    end

    function report = step(obj, varargin)
      [nc, nv, tc, tv] = controls(varargin);
      values = mdr_mex('step', obj.handle, nc, nv, tc, tv);
      report = struct('substeps', values(1), 'path_error', values(2), 'dissipated', values(3));
    end

    function s = state(obj)
      s = mdr_mex('state', obj.handle);
    end

    function [positive, negative] = stiffness(obj)
      k = mdr_mex('stiffness', obj.handle);
      positive = k(1);
      negative = k(2);
    end

    function intervals = slip_intervals(obj)
      intervals = mdr_mex('slip_intervals', obj.handle);
    end

    function [weights, edge] = jager_weights(obj)
      [weights, edge] = mdr_mex('jager_weights', obj.handle);
    end

    function t = tractions(obj, radii, route)
      if nargin < 3, route = 'both'; end
      routes = struct('both', 1, 'abel', 2, 'jager', 3);
      if ~ischar(route) || ~isfield(routes, route)
        error('mdr:invalidArgument', 'route: must be ''both'', ''abel'' or ''jager''');
      end
      t = mdr_mex('tractions', obj.handle, double(radii(:)), routes.(route));
    end

    function bytes = snapshot(obj)
      bytes = mdr_mex('snapshot', obj.handle);
    end
  end

  methods (Static)
    function obj = restore(bytes)
      obj = mdr.Contact('restored', mdr_mex('restore', uint8(bytes)));
    end
  end
end

function [nc, nv, tc, tv] = controls(arguments)
% The step's channels as libmdr_c's controls (0 holds; 1..3 for each channel).
  if numel(arguments) == 1 && isstruct(arguments{1})
    names = fieldnames(arguments{1});
    values = struct2cell(arguments{1});
    arguments = [names'; values'];
    arguments = arguments(:)';
  end
  normal = struct('depth', 1, 'depth_increment', 2, 'normal_force', 3);
  tangential = struct('displacement', 1, 'displacement_increment', 2, 'tangential_force', 3);
  nc = 0; nv = 0; tc = 0; tv = 0;
  if mod(numel(arguments), 2) ~= 0
    error('mdr:invalidArgument', 'step: channels come as name-value pairs');
  end
  for k = 1:2:numel(arguments)
    name = arguments{k};
    value = arguments{k + 1};
    if ~ischar(name)
      error('mdr:invalidArgument', 'step: a channel name must be text');
    end
    if ~(isnumeric(value) && isreal(value) && isscalar(value))
      error('mdr:invalidArgument', '%s: must be a real scalar', name);
    end
    if isfield(normal, name)
      if nc ~= 0, error('mdr:invalidArgument', '%s: a second normal channel in one step', name); end
      nc = normal.(name); nv = double(value);
    elseif isfield(tangential, name)
      if tc ~= 0
        error('mdr:invalidArgument', '%s: a second tangential channel in one step', name);
      end
      tc = tangential.(name); tv = double(value);
    else
      error('mdr:invalidArgument', ['%s: not a channel (depth, depth_increment, normal_force, ' ...
            'displacement, displacement_increment, tangential_force)'], name);
    end
  end
end
