function marked = json_array(x)
% json_array  Marks x as a JSON array for to_json, also when it has one element (internal to +mdr).
  marked = struct('mdr_json_array', {x});
end
