function text = to_json(value)
% to_json  proto3 JSON of a MATLAB value, as mdr_mex's requests need it (internal to +mdr).
%   struct -> object (a struct array -> array of objects); cell -> array; char -> string;
%   logical scalar -> true/false; numeric scalar -> number; numeric array -> array of numbers.
%   mdr.internal.json_array(x) marks a vector that is an array even with one element (repeated fields).
%   Every double is written with 17 significant digits (exact); NaN and +-Inf as proto3 JSON
%   writes them ("NaN", "Infinity", "-Infinity"), so that the service's checks see them.
  if isstruct(value) && isscalar(value) && isequal(fieldnames(value), {'mdr_json_array'})
    text = numbers(value.mdr_json_array);
  elseif isstruct(value) && ~isscalar(value)
    parts = arrayfun(@mdr.internal.to_json, value, 'UniformOutput', false);
    text = ['[' strjoin(parts(:)', ',') ']'];
  elseif isstruct(value)
    names = fieldnames(value);
    parts = cell(1, numel(names));
    for k = 1:numel(names)
      parts{k} = ['"' names{k} '":' mdr.internal.to_json(value.(names{k}))];
    end
    text = ['{' strjoin(parts, ',') '}'];
  elseif iscell(value)
    parts = cellfun(@mdr.internal.to_json, value, 'UniformOutput', false);
    text = ['[' strjoin(parts(:)', ',') ']'];
  elseif ischar(value)
    text = jsonencode(value);
  elseif islogical(value) && isscalar(value)
    if value, text = 'true'; else, text = 'false'; end
  elseif isnumeric(value) && isreal(value) && isscalar(value)
    text = numbers(value);
    text = text(2:end - 1);
  elseif isnumeric(value) && isreal(value)
    text = numbers(value);
  else
    error('mdr:invalidArgument', 'a value of class %s cannot be sent', class(value));
  end
end

function text = numbers(x)
  x = double(x(:)');
  if isempty(x)
    text = '[]';
    return
  end
  text = sprintf('%.17g,', x);
  text = regexprep(text, '(-?)Inf', '"$1Infinity"');
  text = regexprep(text, 'NaN', '"NaN"');
  text = ['[' text(1:end - 1) ']'];
end
