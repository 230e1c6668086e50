function [release, api] = version()
% mdr.version  libmdr_c's release ('0.1.0') and its C interface [version, revision].
  [api, release] = mdr_mex('version');
end
