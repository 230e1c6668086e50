function value = from_json(text, numbers)
% from_json  A response of mdr_mex as a struct (internal to +mdr). mdr_mex has replaced every
%   number of the JSON by its index into `numbers`, which it parsed exactly (jsondecode's own
%   reading of a 17-digit double may be 1 ulp off): jsondecode, then the numbers put back, and
%   the strings proto3 JSON writes for NaN and +-Inf ("NaN", "Infinity", "-Infinity") as numbers.
  value = numbers_back(jsondecode(text), numbers);
end

function value = numbers_back(value, numbers)
  if ischar(value)
    switch value
      case 'NaN', value = NaN;
      case 'Infinity', value = Inf;
      case '-Infinity', value = -Inf;
    end
  elseif isnumeric(value)
    value = reshape(numbers(value + 1), size(value));
  elseif isstruct(value)
    names = fieldnames(value);
    for i = 1:numel(value)
      for k = 1:numel(names)
        value(i).(names{k}) = numbers_back(value(i).(names{k}), numbers);
      end
    end
  elseif iscell(value)
    value = cellfun(@(v) numbers_back(v, numbers), value, 'UniformOutput', false);
    numeric = cellfun(@(v) isnumeric(v) && isscalar(v), value);
    if ~isempty(value) && all(numeric(:))  % an array of numbers with a NaN among them
      value = reshape([value{:}], size(value));
    end
  end
end
