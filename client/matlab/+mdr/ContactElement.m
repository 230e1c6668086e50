classdef ContactElement < handle
% mdr.ContactElement  An exact contact element for harmonic balance (docs/dynamics.md), in this
% process (libmdr_c's mdr_element). SI units.
%
%   e = mdr.ContactElement(scene, normal_force)
%       scene: a struct of mdr.v1.Scene's fields or a scene file's name, as for mdr.Contact: a
%       single contact, or an interface with kind 'KIND_SHARED_MOTION' (its asperities share the
%       motion; normal_force is then their total). Pressed once to normal_force (N, > 0) at u = 0.
%
%   [F, dFdU, energy] = e.aft(U, h, Nt)
%       U: the tangential displacement's coefficients (m) for the harmonics h (increasing, 0
%       first when present), ordered [U0; U1c; U1s; U2c; U2s; ...] as NLvib's and tmdsimpy's
%       sine-cosine form: u(tau) = U0 + sum_h Uhc cos(h tau) + Uhs sin(h tau).
%       Nt: time samples per period, a power of two in [8, 65536] above 2 max(h); default 128.
%       F: the steady periodic force's coefficients (N), a column in the same form; dFdU: their
%       exact Jacobian (N/m; computed only when asked for); energy: J dissipated per period.
%       The element is rate-independent, so dF/domega = 0, and a call never changes it.
%
% Errors are MATLAB errors with identifiers mdr:invalidArgument, ...; the message names the
% argument (samples, harmonics[k], coefficients[i], normal_force, scene.<field>). The element is
% released when the object is cleared.

  properties (Access = private)
    handle
  end

  methods
    function obj = ContactElement(scene, normal_force)
      if nargin ~= 2
        error('mdr:invalidArgument', 'usage: mdr.ContactElement(scene, normal_force)');
      end
      [text, name] = mdr.internal.scene_text(scene);
      obj.handle = mdr_mex('element_create', text, name, normal_force);
    end

    function delete(obj)
      if ~isempty(obj.handle)
        mdr_mex('element_destroy', obj.handle);
        obj.handle = [];
      end
    end

    function [F, dFdU, energy] = aft(obj, U, h, Nt)
      if nargin < 4
        Nt = 128;
      end
      if nargout > 1
        [F, dFdU, energy] = mdr_mex('element_aft', obj.handle, U(:), h(:), Nt);
      else
        F = mdr_mex('element_aft', obj.handle, U(:), h(:), Nt);
      end
    end
  end
end
