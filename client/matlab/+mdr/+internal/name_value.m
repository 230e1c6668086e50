function options = name_value(defaults, arguments, caller)
% name_value  Name-value pairs into a struct of known names (internal to +mdr); an unknown name
%   is an mdr:invalidArgument error naming it.
  options = defaults;
  if mod(numel(arguments), 2) ~= 0
    error('mdr:invalidArgument', '%s: options come as name-value pairs', caller);
  end
  for k = 1:2:numel(arguments)
    name = arguments{k};
    if ~ischar(name) || ~isfield(defaults, name)
      error('mdr:invalidArgument', '%s: unknown option %s (known: %s)', caller, ...
            disp_name(name), strjoin(fieldnames(defaults)', ', '));
    end
    options.(name) = arguments{k + 1};
  end
end

function text = disp_name(name)
  if ischar(name), text = ['''' name '''']; else, text = ['of class ' class(name)]; end
end
